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
import numbers
import os
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Self

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    model_validator,
)

from nanoblock.barriers import (
    BARRIERS,
    BOLTZMANN,
    lattice_barrier_floor,
    reduced_barrier_height,
)


def _number(value: Any) -> Any:
    """Refuse anything but a number where an integer is expected (``true``, ``"4"``)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"an integer is required, not a {type(value).__name__}")
    return value


# Floats are strict (no booleans, no strings; integers are accepted); integers take
# numbers only (numpy integers too; 2.0 is 2, 2.5 is refused).
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False, strict=True)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False, strict=True)]
PositiveOrInf = Annotated[float, Field(gt=0, strict=True)]  # +inf allowed, NaN is not
Count = Annotated[int, BeforeValidator(_number)]

U_MAX = 700.0
"""Largest reduced barrier u = U_a / k_B T: exp(-u) underflows in double precision near
745, and above ~700 the blocks never depin thermally (only athermally at sigma_a)."""

MAX_EVENTS_PER_SAMPLE = 1e8
"""Most block depinnings expected between two stored samples (10-100 s of work at the
engine's throughput, 1e6-1e7 per second); more means a run that does not finish in
practice, or blocks that are not pinned at all."""

MAX_EVENTS = 1e12
"""Most block depinnings expected over a whole run (about a day of work)."""

MAX_BLOCK_UPDATES = 1e13
"""Most block updates expected over a whole run: blocks advanced by the internal steps
(every block at every step; a cheap one costs 2-15 ns, measured 2026-11-29) plus blocks
drawn afresh by contact renewals (about a day of work). Above MAX_EVENTS times the steps
of the default rho~_max / 8, so it binds only on a set ``run.step_slip`` or a short
memory length."""

MAX_DRIVE_RATIO = 1e6
"""Largest drive stiffness K over the pinned interface's k_int: a stiffer drive moves the
slider as a rigid one (K = inf) does, to 1e-6 of the interface's elastic slip. Measured
(2026-11-29, the quick start's protocol): 4-5 s of engine time from K / k_int = 220 to
2.2e6, as at its own 4.4e-4; at 2.2e8 its hold did not finish in two minutes."""

MAX_SAMPLES = 10**9
"""Most stored samples of a run (their times alone take 8 GB of memory)."""

JOINT_DENSITY = 1.0e3
"""Mass density [kg/m^3] used for the default block mass m_b = rho b^3."""

STRENGTH_CLASSES = 8
"""Default number of strength classes when ``joint.threshold_spread`` > 0."""


@contextmanager
def _representable(values: dict[str, Any]) -> Iterator[None]:
    """Refuse ``values`` whose derived quantities over- or underflow double precision."""
    try:
        yield
    except ArithmeticError as error:
        shown = ", ".join(f"{key} = {value!r}" for key, value in values.items())
        raise ValueError(
            f"{shown}: derived quantities leave double precision ({error}); use values "
            "within physical ranges"
        ) from None


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
    back_jumps: bool = Field(False, strict=True, description="reverse hops in detailed balance")
    threshold_spread: NonNegative = Field(
        0.0, description="log-standard deviation of sigma_a across contacts"
    )
    strength_classes: Count | None = Field(
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
        keys = ("block_size", "shear_modulus", "threshold_stress", "temperature", "k1")
        with _representable({key: getattr(self, key) for key in keys}):
            return self._derive()

    def _derive(self) -> Self:
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
            if not (math.isfinite(value) and (value > 0 or name == "k2")):
                raise ArithmeticError(f"{name} would be {value}")
            object.__setattr__(self, name, float(value))
        if self.strength_classes is None:
            classes = STRENGTH_CLASSES if self.threshold_spread > 0.0 else 1
            object.__setattr__(self, "strength_classes", classes)
        if self.back_jumps:
            self._check_back_jumps()
        self._check_barrier()
        if self.threshold_spread > 0.0:
            self._check_strength_classes()
        return self

    def class_factors(self, spread: float | None = None) -> np.ndarray:
        """sigma_a of each strength class over ``threshold_stress`` (at ``spread``, default
        ``threshold_spread``; [1.0] without a spread)."""
        spread = self.threshold_spread if spread is None else spread
        if spread == 0.0:
            return np.ones(1)
        from nanoblock.theory.meanfield import strength_factors  # scipy: only with a spread

        return strength_factors(spread, self.strength_classes)

    def class_barriers(self, spread: float | None = None) -> np.ndarray:
        """Reduced zero-stress barrier u of each strength class (physics.md section 1), at
        ``spread`` (default ``threshold_spread``)."""
        return np.array([
            reduced_barrier_height(
                self.threshold_stress * factor, self.block_size, self.shear_modulus,
                self.temperature,
            )
            for factor in self.class_factors(spread)
        ])  # fmt: skip

    def _class_barriers(self, spread: float) -> tuple[float, float]:
        """The weakest class's sigma_a factor and the strongest class's u at ``spread``."""
        return float(self.class_factors(spread)[0]), float(self.class_barriers(spread)[-1])

    def _check_strength_classes(self) -> None:
        """Refuse a spread whose strongest class never depins (u > U_MAX) or whose weakest
        has no threshold left (sigma_a rounds to 0), naming the largest spread allowed."""
        weakest, strongest = self._class_barriers(self.threshold_spread)
        if weakest > 0.0 and strongest <= U_MAX:
            return
        low, high = 0.0, self.threshold_spread  # the allowed spreads form [0, low]
        for _ in range(60):
            middle = 0.5 * (low + high)
            factor, u = self._class_barriers(middle)
            low, high = (middle, high) if factor > 0.0 and u <= U_MAX else (low, middle)
        why = (
            f"the strongest has u = U_a / k_B T = {strongest:.4g} > {U_MAX:g} (it never "
            "depins thermally)"
            if strongest > U_MAX
            else "the weakest has sigma_a = 0 (no threshold)"
        )
        scale = 10.0 ** (math.floor(math.log10(low)) - 2) if low > 0.0 else 1.0
        shown = math.floor(low / scale) * scale  # three digits, rounded into the range
        raise ValueError(
            f"threshold_spread = {self.threshold_spread!r} over {self.strength_classes} "
            f"strength classes: {why}; allowed for this joint: threshold_spread <= {shown:.3g}"
        )

    def _check_barrier(self) -> None:
        """Refuse a barrier so high (cold joint, strong threshold) that nothing depins."""
        if self.u > U_MAX:
            coldest = self.u * self.temperature / U_MAX
            allowed = (
                f"temperature >= {coldest:.4g} K"
                if math.isfinite(coldest)
                else "a smaller threshold_stress or block_size, or a larger shear_modulus"
            )
            raise ValueError(
                f"at {self.temperature:.4g} K the blocks never depin thermally: "
                f"u = U_a / k_B T = {self.u:.4g} exceeds {U_MAX:g} (U_a from "
                f"threshold_stress = {self.threshold_stress:.4g} Pa, block_size, "
                f"shear_modulus); allowed for this joint: {allowed}"
            )

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
    - ``second_memory_length`` D0_2 with ``second_population`` f: the last
      round(f N_c) contacts are renewed after Exp(D0_2) of slip instead of Exp(D0) (gouge
      fabric, a second contact population): two evolution lengths, with the state effect
      split as b_2 / (b + b_2) = f (each population ages as 001/Eq. 5). The load
      exponent scales D0 only.
    """

    normal_force: Positive = Field(description="normal load W [N]")
    hardness: Positive = Field(description="mean contact pressure p [Pa]; Sigma_r = W / p")
    n_contacts: Count = Field(ge=1, description="number of simulated contacts N_c")
    blocks_per_contact: Count = Field(ge=1, description="nanoblocks in each contact's chain")
    memory_length: PositiveOrInf = Field(
        description="mean contact lifetime in slip D0 [m]; inf disables renewal"
    )
    aging_m: NonNegative = Field(
        0.0,
        le=10.0,
        description="logarithmic area growth m (001/Eq. 5); measured 0.01-0.1, at most 10 "
        "(the area would grow tenfold per e-fold of contact age)",
    )
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
    second_memory_length: PositiveOrInf | None = Field(
        None, description="mean lifetime in slip D0_2 [m] of the second contact population"
    )
    second_population: Positive | None = Field(
        None, lt=1.0, description="fraction f of the contacts in the second population (0, 1)"
    )

    @model_validator(mode="after")
    def _second_population(self) -> Self:
        if (self.second_memory_length is None) != (self.second_population is None):
            raise ValueError(
                "second_memory_length (m) and second_population (a fraction in (0, 1)) "
                "come together: give both or neither"
            )
        if self.second_population is not None and not (
            1 <= self.second_contacts <= self.n_contacts - 1
        ):
            raise ValueError(
                f"second_population = {self.second_population!r} of n_contacts = "
                f"{self.n_contacts} gives {self.second_contacts} contacts; each population "
                "needs at least one (more contacts, or f nearer 1/2)"
            )
        return self

    @property
    def second_contacts(self) -> int:
        """Contacts in the second population, round(f N_c) (0 without one)."""
        return round((self.second_population or 0.0) * self.n_contacts)

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
        keys = ("memory_length", "normal_force", "reference_force", "memory_length_exponent")
        with _representable({key: getattr(self, key) for key in keys}):
            scaled = self.memory_length * (self.normal_force / reference) ** n
            if not 0.0 < scaled < math.inf:
                raise ArithmeticError(f"memory_length at normal_force would be {scaled!r} m")
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

    seed: Count | None = Field(
        None, ge=0, lt=2**63, description="random seed; drawn and recorded if absent"
    )
    record_every: Positive = Field(description="simulated time between stored samples [s]")
    initial_state: Literal["unloaded", "steady"] = Field("unloaded")
    step_slip: Positive | None = Field(
        None,
        description="slider slip per internal step driven by depinnings (with a finite "
        "spring; the whole slip with a rigid one) [m]; default rho~_max / 8 with a finite "
        "spring, unlimited with a rigid one",
    )
    snapshot_every: Count = Field(0, ge=0, description="store block snapshots every N samples")


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

    @model_validator(mode="after")
    def _steady_start_moves(self) -> Self:
        holds = all(step.hold is not None for step in self.loading.steps)
        if self.run.initial_state == "steady" and holds:
            raise ValueError(
                "run.initial_state = 'steady' starts in steady sliding at the first moving "
                "segment's velocity, but every loading.steps segment is a hold: add a moving "
                "segment or start 'unloaded'"
            )
        return self

    @property
    def total_time(self) -> float:
        """Duration of the whole protocol [s]."""
        return float(sum(step.length for step in self.loading.steps))

    @property
    def step_slip(self) -> float:
        """Resolved slider slip per internal step [m].

        A finite spring needs short steps of the depinnings' drift (predicted from the
        previous step; the pinned response is exact, :mod:`nanoblock.kernels.stepper`);
        a rigid one (K = inf) prescribes the slider path, so the blocks' exact ramps run
        uninterrupted to the next sample or segment end (inf)."""
        if self.run.step_slip is not None:
            return self.run.step_slip
        return np.inf if self.loading.stiffness == np.inf else self.joint.rho_max / 8

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


BYTES_PER_BLOCK = 64
"""Memory per block of a run: its stretch and hazard, the initial state's temporaries."""

BYTES_PER_CONTACT = 128
"""Memory per contact: age, slip, lifetime, events, random streams, scratch."""


@dataclass(frozen=True)
class Requirements:
    """What a scenario needs before it runs: sizes, memory [B], expected depinnings."""

    samples: float
    blocks: int
    memory: float
    thermal_rate: float  # zero-stress escape rate per block, mean over classes [1/s]
    driven_rate: float  # threshold crossings per block at the fastest drive [1/s]
    crossings_per_travel: float  # threshold crossings per block and m of travel [1/m]
    events_per_sample: float
    events: float
    interface_stiffness: float  # k_int of the pinned interface at birth [N/m]
    steps: float  # internal steps, at least: one per sample plus the drift's (stepper)
    renewals: float  # contact renewals over the load-point travel
    block_updates: float  # blocks advanced by the steps plus blocks renewed


def requirements(scenario: Scenario) -> Requirements:
    """Estimate the samples, memory and block depinnings of a run (nothing is allocated)."""
    joint, interface, run = scenario.joint, scenario.interface, scenario.run
    samples = scenario.total_time / run.record_every + 1
    blocks = interface.n_contacts * interface.blocks_per_contact
    memory = 8.0 * samples + BYTES_PER_BLOCK * blocks + BYTES_PER_CONTACT * interface.n_contacts
    # averaged over the strength classes: a weak class hops and crosses most often
    barriers = np.minimum(joint.class_barriers(), U_MAX)
    thermal = float(joint.attempt_frequency * np.mean(np.exp(-barriers)))
    per_travel = float(np.mean(1.0 / (joint.rho_max * joint.class_factors())))
    velocity = max(step.load_velocity for step in scenario.loading.steps)
    driven = velocity * per_travel
    travel = sum(step.load_velocity * step.length for step in scenario.loading.steps)
    per_sample = blocks * run.record_every * (thermal + driven)
    events = blocks * (thermal * scenario.total_time + travel * per_travel)
    area = interface.normal_force / interface.hardness
    k_int = area * joint.threshold_stress / joint.rho_max
    spring = scenario.loading.stiffness
    # the stepper's drift runs at least V_L - V_f = V_L k_int / (K + k_int) (V_L if rigid)
    share = 1.0 if spring == math.inf else k_int / (spring + k_int)
    steps = samples + travel * share / scenario.step_slip
    second = interface.second_contacts
    renewals = travel * (
        (interface.n_contacts - second) / interface.memory_length
        + (second / interface.second_memory_length if second else 0.0)
    )
    updates = steps * blocks + renewals * interface.blocks_per_contact
    return Requirements(
        samples, blocks, memory, thermal, driven, per_travel, per_sample, events, k_int,
        steps, renewals, updates,
    )  # fmt: skip


def check_feasible(scenario: Scenario, source: str = "scenario") -> None:
    """Refuse, before anything is allocated, a run of ``scenario`` that this machine
    cannot hold (samples, memory) or finish (expected depinnings per sample and in all):
    ScenarioError naming the keys, what the run would need and what is allowed."""
    try:
        _feasible(scenario)
    except ValueError as error:
        raise ScenarioError(f"{source}: cannot run: {error}") from None


def _feasible(scenario: Scenario) -> None:
    """ValueError naming what ``scenario`` would need, if more than is allowed."""
    joint = scenario.joint
    with _representable(
        {"joint.rho_max (threshold_stress b^2 / k1)": joint.rho_max, "joint.u": joint.u}
    ):
        needs = requirements(scenario)
    run, interface = scenario.run, scenario.interface
    area = interface.normal_force / interface.hardness
    stiffness = needs.interface_stiffness
    if not (0.0 < area * joint.threshold_stress < math.inf and 0.0 < stiffness < math.inf):
        raise ValueError(
            f"interface.normal_force = {interface.normal_force!r} N over interface.hardness "
            f"= {interface.hardness!r} Pa is a real contact area of {area:.3g} m^2: its "
            f"friction force ({area * joint.threshold_stress:.3g} N at sigma_a) and stiffness "
            f"({stiffness:.3g} N/m) leave double precision; use values within physical ranges"
        )
    if needs.samples > MAX_SAMPLES:
        raise ValueError(
            f"run.record_every = {run.record_every!r} s over the protocol's "
            f"{scenario.total_time:.4g} s would store {needs.samples:.3g} samples; at most "
            f"{MAX_SAMPLES:.0e} are allowed (record_every >= "
            f"{scenario.total_time / MAX_SAMPLES:.3g} s)"
        )
    available = physical_memory()
    if needs.memory > available:
        raise ValueError(
            f"interface.n_contacts = {interface.n_contacts} x "
            f"interface.blocks_per_contact = {interface.blocks_per_contact} = "
            f"{needs.blocks:.3g} blocks and {needs.samples:.3g} samples would need "
            f"{needs.memory / 1e9:.3g} GB of memory; this machine has "
            f"{available / 1e9:.3g} GB"
        )
    if needs.events_per_sample > MAX_EVENTS_PER_SAMPLE:
        spread = joint.threshold_spread > 0.0
        weakest = f", weakest strength class {joint.class_barriers()[0]:.3g}" if spread else ""
        raise ValueError(
            f"the {needs.blocks:.3g} blocks would depin ~{needs.events_per_sample:.3g} "
            f"times per sample (run.record_every = {run.record_every!r} s): at "
            f"{joint.temperature:.4g} K they hop over their barrier without load "
            f"(u = {joint.u:.4g}{weakest}: {needs.thermal_rate:.3g} /s per block) and sliding "
            f"moves each across rho~_max {needs.driven_rate:.3g} times per s; at most "
            f"{MAX_EVENTS_PER_SAMPLE:.0e} per sample are allowed: lower "
            "joint.temperature, run.record_every or the number of blocks"
        )
    if needs.events > MAX_EVENTS:
        raise ValueError(
            f"the run would take ~{needs.events:.3g} block depinnings (days of work); "
            f"at most {MAX_EVENTS:.0e} are allowed: fewer blocks or a shorter protocol"
        )
    _feasible_steps(scenario, needs)


def _feasible_steps(scenario: Scenario, needs: Requirements) -> None:
    """ValueError naming the drive stiffness, step or memory length whose internal steps
    or contact renewals no run would finish."""
    spring, k_int = scenario.loading.stiffness, needs.interface_stiffness
    if math.inf > spring > MAX_DRIVE_RATIO * k_int:
        raise ValueError(
            f"loading.stiffness = {spring!r} N/m is {spring / k_int:.3g} times the pinned "
            f"interface's stiffness k_int = {k_int:.3g} N/m (real area "
            "interface.normal_force / interface.hardness times joint.threshold_stress / "
            f"rho~_max); above {MAX_DRIVE_RATIO:.0e} times it is a rigid drive to 1e-6 of "
            "the slip: use loading.stiffness = inf, or at most "
            f"{MAX_DRIVE_RATIO * k_int:.3g} N/m"
        )
    if needs.block_updates <= MAX_BLOCK_UPDATES:
        return
    interface, blocks = scenario.interface, needs.blocks
    if needs.renewals * interface.blocks_per_contact > needs.steps * blocks:
        shortest = min(interface.memory_length, interface.second_memory_length or math.inf)
        key = "memory_length" if shortest == interface.memory_length else "second_memory_length"
        raise ValueError(
            f"interface.{key} = {shortest!r} m renews contacts ~{needs.renewals:.3g} times "
            f"over the protocol's load travel, each drawing {interface.blocks_per_contact} "
            f"blocks afresh; at most {MAX_BLOCK_UPDATES:.0e} block updates are allowed "
            "(about a day of work): a longer memory length or a shorter protocol"
        )
    raise ValueError(
        f"run.step_slip = {scenario.step_slip!r} m takes ~{needs.steps:.3g} internal steps, "
        f"each advancing all {blocks:.3g} blocks; at most {MAX_BLOCK_UPDATES:.0e} block "
        "updates are allowed (about a day of work): a longer run.step_slip (default "
        f"rho~_max / 8 = {scenario.joint.rho_max / 8:.3g} m), fewer blocks or samples "
        "(run.record_every), or a shorter protocol"
    )


def physical_memory() -> float:
    """Physical memory of this machine [B] (inf where the platform does not say)."""
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return math.inf


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
    low, high = ctx.get("gt", ctx.get("ge")), ctx.get("lt", ctx.get("le"))
    if high is not None:
        return f" (allowed: {'at most' if 'le' in ctx else 'below'} {high})"
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
    """The raw mapping of a TOML scenario file (UTF-8, with or without the byte-order mark
    some editors write); ``ScenarioError`` if missing or invalid."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8-sig"))  # a byte-order mark too
    except FileNotFoundError:
        raise ScenarioError(f"{path}: scenario file not found") from None
    except IsADirectoryError:
        raise ScenarioError(f"{path}: is a directory; a scenario TOML file is required") from None
    except UnicodeDecodeError as error:
        raise ScenarioError(f"{path}: not a UTF-8 text file ({error.reason})") from None
    except OSError as error:
        raise ScenarioError(f"{path}: cannot be read ({error.strerror})") from None
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
