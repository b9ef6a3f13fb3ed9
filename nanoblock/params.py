"""Validated scenario parameters: joint, interface, loading and run (TOML scenario files).

Every scenario key maps one-to-one onto a field below; unknown keys, non-finite or
out-of-range values are errors that name the key, the value and the allowed range
(nothing is clipped). Optional joint keys are resolved to concrete numbers, so the
scenario stored with a run (``Scenario.resolved_json``) reproduces it on its own.
SI units throughout; equation numbers refer to ``physics.md`` and the papers 000/001.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal, Self

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from nanoblock.barriers import (
    BARRIERS,
    BOLTZMANN,
    lattice_barrier_floor,
    reduced_barrier_height,
)

Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
PositiveOrInf = Annotated[float, Field(gt=0)]  # +inf allowed and meaningful, NaN is not

JOINT_DENSITY = 1.0e3
"""Mass density [kg/m^3] used for the default block mass m_b = rho b^3."""

STRENGTH_CLASSES = 8
"""Default number of strength classes when ``joint.threshold_spread`` > 0."""


class ScenarioError(ValueError):
    """A scenario that cannot be run: the message names the key and the allowed range."""


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, ser_json_inf_nan="constants")

    @model_validator(mode="before")
    @classmethod
    def _no_nan(cls, data: Any) -> Any:
        if isinstance(data, dict):
            for key, value in data.items():
                if isinstance(value, float) and math.isnan(value):
                    raise ValueError(f"{key} is NaN; a finite number is required")
        return data


class Joint(_Section):
    """The adhesive joint of one micro-contact: a chain of nanoblocks (001/Eq. 21, 24, 37).

    Optional stiffnesses, mass, damping and attempt frequency default to the estimates of
    001 Sec. III.C-D: k1 = k2 = E_J b, m_b = rho_J b^3 (rho_J = 1000 kg/m^3), a damping
    that makes an isolated interior block critically damped (its slip ends at zero force,
    the chain analogue of the mean-field reset), and omega_a = c_J / b with
    c_J = (E_J b^3 / m_b)^(1/2).

    Catalogue extensions (physics.md section 5), all off by default:

    - ``back_jumps``: blocks live on Persson's periodic characteristic and hop one period
      rho~_max forward (x -> x - 1) or back (x -> x + 1), thermally and in detailed
      balance (:func:`nanoblock.barriers.lattice_reverse_barrier`); mean-field joint only.
    - ``threshold_spread``: sigma_a lognormal across contacts with this log-standard
      deviation and mean ``threshold_stress``, discretised into ``strength_classes``
      equal-probability classes (:func:`nanoblock.theory.meanfield.strength_factors`).
    - ``glass_temperature`` T_g: ``threshold_stress`` is given at
      ``reference_temperature`` T_ref and softens linearly to zero at T_g,
      sigma_a(T) = sigma_a(T_ref) (T_g - T) / (T_g - T_ref) (001/Figs. 9, 12). The
      resolved joint holds sigma_a(T) with ``reference_temperature`` = T, so that it
      reproduces the run on its own; rho~_max, u and the default step slip use sigma_a(T).
    """

    block_size: Positive = Field(description="block edge b [m]")
    shear_modulus: Positive = Field(description="joint shear modulus E_J [Pa]")
    threshold_stress: Positive = Field(description="athermal depinning stress sigma_a [Pa]")
    k1: Positive | None = Field(None, description="block-to-plate spring [N/m]")
    k2: NonNegative | None = Field(None, description="block-to-block spring [N/m]")
    block_mass: Positive | None = Field(None, description="block mass m_b [kg]")
    damping: Positive | None = Field(None, description="internal damping gamma [1/s]")
    attempt_frequency: Positive | None = Field(None, description="omega_a [1/s]")
    temperature: Positive = Field(description="temperature T [K]")
    barrier: Literal[tuple(BARRIERS)] = Field("persson", description="barrier law")  # type: ignore[valid-type]
    slip: Literal["chain", "reset"] = Field("chain", description="slip rule")
    back_jumps: bool = Field(False, description="reverse hops in detailed balance")
    threshold_spread: NonNegative = Field(
        0.0, description="log-standard deviation of sigma_a across contacts"
    )
    strength_classes: int | None = Field(
        None, ge=1, description="strength classes; default 1 without spread, else 8"
    )
    glass_temperature: PositiveOrInf = Field(
        math.inf, description="T_g [K] of the softening law; inf = no softening"
    )
    reference_temperature: Positive | None = Field(
        None, description="T_ref [K] at which threshold_stress is given (with T_g)"
    )

    @model_validator(mode="after")
    def _resolve(self) -> Self:
        self._soften()
        b, e_j = self.block_size, self.shear_modulus
        k1 = self.k1 if self.k1 is not None else e_j * b
        k2 = self.k2 if self.k2 is not None else e_j * b
        mass = self.block_mass if self.block_mass is not None else JOINT_DENSITY * b**3
        damping = (
            self.damping if self.damping is not None else 2.0 * math.sqrt((k1 + 2 * k2) / mass)
        )
        omega = (
            self.attempt_frequency
            if self.attempt_frequency is not None
            else math.sqrt(e_j * b**3 / mass) / b
        )
        for name, value in (
            ("k1", k1),
            ("k2", k2),
            ("block_mass", mass),
            ("damping", damping),
            ("attempt_frequency", omega),
        ):
            object.__setattr__(self, name, float(value))
        if self.strength_classes is None:
            classes = STRENGTH_CLASSES if self.threshold_spread > 0.0 else 1
            object.__setattr__(self, "strength_classes", classes)
        if self.back_jumps:
            self._check_back_jumps()
        return self

    def _soften(self) -> None:
        """Replace sigma_a(T_ref) by sigma_a(T) of the linear softening law near T_g."""
        t_g, t_ref, t = self.glass_temperature, self.reference_temperature, self.temperature
        if math.isinf(t_g):
            if t_ref is not None:
                raise ValueError(
                    "reference_temperature has no effect without a finite glass_temperature"
                )
            return
        if t_ref is None:
            raise ValueError(
                "glass_temperature needs reference_temperature (K), the temperature at "
                "which threshold_stress is given"
            )
        for name, value in (("temperature", t), ("reference_temperature", t_ref)):
            if not value < t_g:
                raise ValueError(
                    f"{name} = {value!r} K must be below glass_temperature = {t_g!r} K "
                    f"(allowed range (0, {t_g!r}))"
                )
        softened = self.threshold_stress * ((t_g - t) / (t_g - t_ref))  # exact when t = t_ref
        object.__setattr__(self, "threshold_stress", float(softened))
        object.__setattr__(self, "reference_temperature", float(t))

    def _check_back_jumps(self) -> None:
        if self.slip != "reset" or self.k2 != 0.0:
            raise ValueError(
                "back_jumps = true is defined for the mean-field joint only: it needs "
                f"slip = 'reset' and k2 = 0 (got slip = {self.slip!r}, k2 = {self.k2!r})"
            )
        floor = lattice_barrier_floor(self.barrier, self.u, self.u_elastic)
        if floor < 0.0:
            raise ValueError(
                f"back_jumps = true: the reverse-hop barrier u f(s) + u_el (s - 1/2) falls to "
                f"{floor:.3g} k_B T < 0 (u = {self.u:.4g}, u_el = k1 rho~_max^2 / k_B T = "
                f"{self.u_elastic:.4g}); it is non-negative for k1 >= E_J b / 2 (Persson)"
            )

    @property
    def u_elastic(self) -> float:
        """u_el = k1 rho~_max^2 / k_B T: elastic energy of one period of the characteristic."""
        return self.k1 * self.rho_max**2 / (BOLTZMANN * self.temperature)

    @property
    def rho_max(self) -> float:
        """rho~_max = b^2 sigma_a / k1 [m]: drive displacement from zero stress to sigma_a."""
        return self.block_size**2 * self.threshold_stress / self.k1

    @property
    def u(self) -> float:
        """Reduced zero-stress barrier u = U_a / k_B T (physics.md section 1)."""
        return reduced_barrier_height(
            self.threshold_stress, self.block_size, self.shear_modulus, self.temperature
        )


class Interface(_Section):
    """The multicontact interface: contacts as agents that age and are renewed (001/Eqs. 1-5).

    Catalogue extensions (physics.md section 5), all off by default:

    - ``state_cutoff_velocity`` v_theta: a contact's ageing clock runs at V / (V + v_theta)
      (V: slider velocity), so contacts do not age at rest and the steady mean age is
      D0 / (V + v_theta): with theta = v_theta <age> / D0 this is 000/Eq. 7.
    - ``memory_length_exponent`` n with ``reference_force`` W_ref: D0(W) =
      ``memory_length`` (W / W_ref)^n (000/Fig. 3 caption). The resolved interface holds
      D0(W) with ``reference_force`` = W, so that it reproduces the run on its own.
    """

    normal_force: Positive = Field(description="normal load W [N]")
    hardness: Positive = Field(description="mean contact pressure p [Pa]; Sigma_r = W / p")
    n_contacts: int = Field(ge=1, description="number of simulated contacts N_c")
    blocks_per_contact: int = Field(ge=1, description="nanoblocks in each contact's chain")
    memory_length: PositiveOrInf = Field(
        description="mean contact lifetime in slip D0 [m]; inf disables renewal"
    )
    aging_m: NonNegative = Field(0.0, description="logarithmic area growth m (001/Eq. 5)")
    aging_time: Positive = Field(1e-3, description="creep onset time tau_m [s] (001/Eq. 5)")
    state_cutoff_velocity: PositiveOrInf | None = Field(
        None, description="v_theta [m/s] of 000/Eq. 7; absent = the clock always runs"
    )
    memory_length_exponent: NonNegative = Field(
        0.0, description="n in D0(W) = memory_length (W / W_ref)^n"
    )
    reference_force: Positive | None = Field(
        None, description="W_ref [N] at which memory_length is given (with n > 0)"
    )

    @model_validator(mode="after")
    def _load_dependent_memory(self) -> Self:
        n, reference = self.memory_length_exponent, self.reference_force
        if n == 0.0:
            if reference is not None:
                raise ValueError("reference_force has no effect with memory_length_exponent = 0")
            return self
        if reference is None:
            raise ValueError(
                "memory_length_exponent > 0 needs reference_force (N), the normal load "
                "at which memory_length is given"
            )
        scaled = self.memory_length * (self.normal_force / reference) ** n
        object.__setattr__(self, "memory_length", float(scaled))
        object.__setattr__(self, "reference_force", float(self.normal_force))
        return self

    @property
    def real_area(self) -> float:
        """Real contact area at birth Sigma_r = W / p [m^2]."""
        return self.normal_force / self.hardness


class Step(_Section):
    """One load-point segment: {velocity, duration}, {velocity, displacement} or {hold}."""

    velocity: Positive | None = Field(None, description="load-point velocity [m/s]")
    duration: Positive | None = Field(None, description="segment duration [s]")
    displacement: Positive | None = Field(None, description="load-point travel [m]")
    hold: Positive | None = Field(None, description="hold duration at rest [s]")

    @model_validator(mode="after")
    def _one_form(self) -> Self:
        if self.hold is not None:
            if any(v is not None for v in (self.velocity, self.duration, self.displacement)):
                raise ValueError("a hold step takes only 'hold' (s)")
        elif self.velocity is None:
            raise ValueError(
                "a step needs 'velocity' (m/s) with 'duration' or 'displacement', or 'hold' (s)"
            )
        elif (self.duration is None) == (self.displacement is None):
            raise ValueError(
                "a velocity step needs exactly one of 'duration' (s) or 'displacement' (m)"
            )
        return self

    @property
    def load_velocity(self) -> float:
        """Load-point velocity during the segment [m/s] (0 for a hold)."""
        return 0.0 if self.hold is not None else float(self.velocity)

    @property
    def length(self) -> float:
        """Segment duration [s]."""
        if self.hold is not None:
            return self.hold
        if self.duration is not None:
            return self.duration
        return self.displacement / self.velocity


class Loading(_Section):
    """Drive spring and load-point protocol (physics.md section 2: K (X_L - X) = F)."""

    stiffness: PositiveOrInf = Field(description="drive stiffness K [N/m]; inf = rigid drive")
    steps: list[Step] = Field(min_length=1, description="load-point segments, in order")

    @property
    def first_velocity(self) -> float:
        """Velocity of the first moving segment [m/s] (used for steady initial states)."""
        for step in self.steps:
            if step.hold is None:
                return float(step.velocity)
        raise ScenarioError("loading.steps: no segment moves the load point")


class Run(_Section):
    """Run control: seed, sampling, initial state and numerics."""

    seed: int | None = Field(None, ge=0, description="random seed; drawn and recorded if absent")
    record_every: Positive = Field(description="simulated time between stored samples [s]")
    initial_state: Literal["unloaded", "steady"] = Field("unloaded")
    step_slip: Positive | None = Field(
        None,
        description="slider slip per internal step driven by depinnings, beyond the pinned "
        "interface's exact elastic response [m]; default rho~_max",
    )
    snapshot_every: int = Field(0, ge=0, description="store block snapshots every N samples")


class Scenario(_Section):
    """A complete, validated scenario (one TOML file)."""

    joint: Joint
    interface: Interface
    loading: Loading
    run: Run

    @model_validator(mode="after")
    def _classes_fill_evenly(self) -> Self:
        n_contacts, classes = self.interface.n_contacts, self.joint.strength_classes
        if n_contacts % classes:
            raise ValueError(
                f"interface.n_contacts = {n_contacts} must be a multiple of "
                f"joint.strength_classes = {classes}: every strength class holds the same "
                "number of contacts"
            )
        return self

    @property
    def total_time(self) -> float:
        """Duration of the whole protocol [s]."""
        return float(sum(step.length for step in self.loading.steps))

    @property
    def step_slip(self) -> float:
        """Resolved depinning-driven slider slip per internal step [m].

        Between depinnings the slider follows the load point in closed form; only the
        slip the depinnings drive is predicted, one step ahead (:mod:`nanoblock.kernels.
        stepper`), so only it is bounded. A stiff or rigid drive leaves little or none,
        and its steps run to the next sample or segment end."""
        if self.run.step_slip is not None:
            return self.run.step_slip
        return self.joint.rho_max

    def with_seed(self, seed: int) -> Scenario:
        """Copy of the scenario with ``run.seed`` set."""
        return self.model_copy(update={"run": self.run.model_copy(update={"seed": seed})})

    def resolved_json(self) -> str:
        """The resolved scenario as JSON (inf written as ``Infinity``)."""
        return self.model_dump_json()

    @classmethod
    def from_json(cls, text: str) -> Scenario:
        """Inverse of :meth:`resolved_json`."""
        return from_mapping(json.loads(text), source="stored scenario")


def _format_errors(error: ValidationError, source: str) -> str:
    lines = [f"{source}: invalid scenario"]
    for item in error.errors():
        key = ".".join(str(part) for part in item["loc"])
        if item["type"] == "extra_forbidden":
            lines.append(f"  unknown key '{key}'")
            continue
        value = item.get("input")
        shown = "" if isinstance(value, dict | list) else f" = {value!r}"
        message = item["msg"].removeprefix("Value error, ")
        bounds = item.get("ctx") or {}
        allowed = _allowed_range(bounds)
        lines.append(f"  {key}{shown}: {message}{allowed}" if key else f"  {message}")
    return "\n".join(lines)


def _allowed_range(ctx: dict[str, Any]) -> str:
    low = ctx.get("gt", ctx.get("ge"))
    if low is None:
        return ""
    bracket = "(" if "gt" in ctx else "["
    return f" (allowed range {bracket}{low}, inf))"


def from_mapping(data: dict[str, Any], source: str = "scenario") -> Scenario:
    """Validate a nested mapping (as read from TOML) into a :class:`Scenario`."""
    try:
        return Scenario.model_validate(data)
    except ValidationError as error:
        raise ScenarioError(_format_errors(error, source)) from None


def read_toml(path: str | Path) -> dict[str, Any]:
    """The raw mapping of a TOML scenario file; ``ScenarioError`` if missing or invalid."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ScenarioError(f"{path}: scenario file not found") from None
    except tomllib.TOMLDecodeError as error:
        raise ScenarioError(f"{path}: not valid TOML ({error})") from None


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a TOML scenario file."""
    return from_mapping(read_toml(path), source=str(path))


def resolve_seed(scenario: Scenario, seed: int | None = None) -> Scenario:
    """Return the scenario with a concrete seed: ``seed``, the file's, or fresh entropy."""
    if seed is not None:
        return scenario.with_seed(seed)
    if scenario.run.seed is not None:
        return scenario
    return scenario.with_seed(int(np.random.SeedSequence().entropy % (2**63)))
