"""The catalogue of effects the base model may miss (physics.md section 5), as a registry.

Each entry names a physical cause in one sentence, the parameters its extension adds, the
simulator option that switches it on, and its coarse-grained surrogate for each kind of
data where it leaves a signature: an RSF variant (law, slip trend, load-dependent D_c)
for time series and clamped-sample curves, a :class:`SteadyVariant` of the mean-field
surrogate for steady-state tables. An entry without a surrogate for a kind of data is
reported as not testable on it, with the data that would be needed.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from nanoblock.diagnosis.steady import SteadyVariant
from nanoblock.rsf.fit import INITIAL_OFFSET, INITIAL_VELOCITY, LOAD_EXPONENT


@dataclass(frozen=True)
class RsfVariant:
    """An RSF surrogate: a law of :mod:`nanoblock.rsf.laws`, optionally with a linear slip
    trend and a load-dependent memory length D_c (W / W_ref)^n."""

    law: str
    trend: bool = False
    load_exponent: bool = False
    fit_stiffness: bool = False
    """K/W fitted even where the metadata state it."""
    initial_state: bool = False
    """A free initial state per run (the record does not start in steady sliding)."""
    cohesion: bool = False
    """A friction level mu0 + (c / sigma_ref) (W_ref / W - 1) across runs at several loads."""
    explore: tuple[str, ...] = ()
    """Parameters searched on a grid when the fit is warm-started from the base fit."""


Surrogate = RsfVariant | SteadyVariant

BASE: dict[str, Surrogate] = {
    "time_series": RsfVariant("aging"),
    "clamped_sample": RsfVariant("silicon"),
    "steady_state": SteadyVariant(),
}
"""The base model's surrogate per kind of data: the aging law that ageing and renewal of
contacts map to (001/Eqs. 3, 16), 000's law in its apparatus (000/Eqs. 9-14), and the
mean-field quadrature with logarithmic ageing for steady tables. On time series the
aging law is one of two :data:`CLOSURES`."""

CLOSURES: dict[str, dict[str, str]] = {
    "aging": {},
    "renewal": {
        "aging": "renewal",
        "cutoff": "renewal_cutoff",
        "saturation": "renewal_saturation",
        "aging2": "renewal2",
    },
}
"""How a time-series surrogate closes the contacts' renewal population (001/Eqs. 3, 5),
as law substitutions: the aging law writes b ln <age> (theta the mean age), the renewal
laws keep b <ln age> (:class:`~nanoblock.rsf.laws.RenewalLaw`). Both have the same
parameters and steady state and differ in transients by up to ~15 % of b; the diagnosis
fits the base with each and takes the extensions in the closure whose base fits better
(laws not listed, such as the slip law, are the same in both)."""


def in_closure(surrogate: Surrogate, closure: str) -> Surrogate:
    """``surrogate`` with its law in ``closure`` (a key of :data:`CLOSURES`)."""
    if not isinstance(surrogate, RsfVariant) or surrogate.law not in CLOSURES[closure]:
        return surrogate
    return replace(surrogate, law=CLOSURES[closure][surrogate.law])


@dataclass(frozen=True)
class Effect:
    """One catalogue entry (physics.md section 5)."""

    id: str
    cause: str
    signature: str
    parameters: dict[str, str]
    simulator: str
    """Scenario key(s) that switch the effect on in the nanoblock simulator."""
    surrogates: dict[str, Surrogate] = field(default_factory=dict)
    needs: str = ""
    """What data would show the effect when it cannot be tested on the data at hand."""
    varies: str | None = None
    """A column that must take two or more values for the effect to be testable."""
    ranges: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Physically plausible range [low, high] of each parameter the extension adds (SI);
    a fit outside it is not accepted as the cause."""
    detector: str = ""
    """For an effect no smooth surrogate can fit: what recognises it in the record."""


CATALOGUE: dict[str, Effect] = {
    effect.id: effect
    for effect in (
        Effect(
            "barrier_shape",
            "the activation barrier is a generic saddle-node one, "
            "dU ~ (1 - sigma/sigma_a)^(3/2), not Persson's 1 - (sigma/sigma_a)^2",
            "curvature of steady mu against ln V: direct effect ~ [ln(V*/V)]^(2/3)",
            {},
            'joint.barrier = "spinodal"',
            {"steady_state": SteadyVariant(barrier="spinodal")},
            "a steady-state table over several decades of velocity",
        ),
        Effect(
            "back_jumps",
            "blocks also hop one period back against the stress, thermally, in detailed "
            "balance with the forward hops (Persson's periodic characteristic)",
            "at low V friction falls towards zero faster than the log law (asinh, then "
            "linear below the Maxwell point)",
            {"elastic_ratio": "u_el / u = E_J b / k1, in (0, 2]"},
            "joint.back_jumps = true",
            {"steady_state": SteadyVariant(back_jumps=True)},
            "a steady-state table reaching very low velocities",
        ),
        Effect(
            "velocity_saturation",
            "contact ageing starts only after a finite creep onset time tau_m, so the "
            "state effect saturates above V_sat = D0 / tau_m (001/Eqs. 5, 8)",
            "the rate weakening (or strengthening) flattens at high V",
            {"tau_m": "creep onset time [s]", "v_saturation": "D0 / tau_m [m/s]"},
            "interface.aging_time (tau_m)",
            {
                "time_series": RsfVariant("saturation", explore=("tau_m",)),
                "steady_state": SteadyVariant(area="saturation"),
            },
            # from a microsecond to a day (001's V_sat = 11 um/s over D0 ~ 1 um: ~0.1 s)
            ranges={"tau_m": (1e-6, 1e5)},
        ),
        Effect(
            "aging_rate",
            "stationary contacts do not heal: state evolves only with slip (000/Fig. 4, "
            "000/Eq. 7), or ageing runs on a separate clock (000/Eqs. 4-5)",
            "slide-hold-slide peaks and the relaxation after steps unlike the aging law",
            {"aging_rate": "separate ageing rate h [1/s] (clamped samples)"},
            "interface.aging_m = 0 with renewal, or interface.state_cutoff_velocity",
            {
                "time_series": RsfVariant("slip", explore=("dc",)),
                "clamped_sample": RsfVariant("two_state", explore=("aging_rate",)),
            },
            "velocity steps, slide-hold-slide or clamped-sample curves",
        ),
        Effect(
            "state_velocity_cutoff",
            "the state law has a cutoff velocity v_theta (000/Eq. 7): contacts age at rate "
            "V / (V + v_theta), so the state stops growing below v_theta",
            "steady state flattens on the slow side of v_theta; relaxation after steps and "
            "holds changes shape",
            {"v_theta": "state cutoff velocity [m/s]"},
            "interface.state_cutoff_velocity",
            {
                "time_series": RsfVariant("cutoff", explore=("v_theta",)),
                "steady_state": SteadyVariant(area="cutoff"),
            },
            # 000 measured 0.03-1.5 um/s (Table 1); above 1 cm/s no lab slides quasi-statically
            ranges={"v_theta": (1e-12, 1e-2)},
        ),
        Effect(
            "load_dependent_dc",
            "the memory length grows with normal load: larger contacts need more slip to "
            "be renewed (000/Fig. 3 caption)",
            "a D_c misfit that trends with the normal force across loads",
            {"dc_load_exponent": "n in D_c ~ W^n"},
            "interface.memory_length_exponent",
            {
                "time_series": RsfVariant("aging", load_exponent=True, explore=(LOAD_EXPONENT,)),
                "clamped_sample": RsfVariant("silicon", load_exponent=True),
            },
            "transients (steps, holds or clamped-sample curves) at two or more normal forces",
            varies="normal_force",
            # 000/Fig. 3 caption: D_c linear in N (n = 1); no mechanism shrinks the memory
            # with load (1.5 leaves room for a fit's error above linear)
            ranges={"dc_load_exponent": (0.0, 1.5)},
        ),
        Effect(
            "strength_heterogeneity",
            "the depinning threshold sigma_a is distributed across asperities",
            "a smeared cutoff: rounder sigma_s(V) near saturation",
            {"strength_spread": "log-standard deviation of sigma_a"},
            "joint.threshold_spread",
            {"steady_state": SteadyVariant(spread=True)},
            "a steady-state table reaching the high-velocity saturation",
        ),
        Effect(
            "joint_softening",
            "the joint softens near T_g: sigma_a (and E_J) fall with temperature (001/Figs. 9, 12)",
            "A(T) rising faster than T, friction level falling with T",
            {"softening": "-d ln sigma_a / d ln T"},
            "joint.glass_temperature",
            {"steady_state": SteadyVariant(softening=True)},
            "a steady-state table at two or more temperatures",
            varies="temperature",
        ),
        Effect(
            "slip_trend",
            "the interface itself evolves with slip (wear, gouge compaction, layer "
            "thinning), so friction drifts linearly with slip",
            "residuals trending linearly with displacement across steps",
            {"slip_trend": "d mu / d slip [1/m]"},
            "(none: an apparatus and wear effect outside the nanoblock model)",
            {"time_series": RsfVariant("aging", trend=True)},
            "a friction time series with slip",
            ranges={"slip_trend": (-1e3, 1e3)},
        ),
        Effect(
            "two_state_variable",
            "two evolution lengths: a contact-scale D_c and a longer D_c2 (gouge fabric, "
            "porosity, a second contact population), each state relaxing by the aging law",
            "a sharp decay after a step followed by a slow tail; one-state D_c grows with "
            "the fit window",
            {"b2": "second evolution coefficient", "dc2": "second memory length D_c2 [m]"},
            "interface.second_memory_length with interface.second_population",
            {"time_series": RsfVariant("aging2", explore=("dc2",))},
            "velocity steps with several D_c of slip after the step",
            ranges={"b2": (-0.05, 0.05), "dc2": (1e-7, 1e-1)},
        ),
        Effect(
            "non_steady_history",
            "the record does not start in steady sliding: a preceding step, hold or "
            "normal-stress change is still relaxing",
            "drift before the step; a slip trend that does not forecast",
            {
                "initial_state_offset_<run>": "ln(theta(0) / theta_ss(V(0))) per run",
                "initial_velocity_offset_<run>": "ln(v(0) / V(0)) per run",
            },
            "a loading step at another velocity before the record (loading.steps)",
            {
                "time_series": RsfVariant(
                    "aging",
                    initial_state=True,
                    explore=(INITIAL_OFFSET, INITIAL_VELOCITY),
                )
            },
            "a friction time series with slip before the first step",
            ranges={
                "initial_state_offset": (-10.0, 10.0),
                "initial_velocity_offset": (-10.0, 10.0),
            },
        ),
        Effect(
            "load_dependent_level",
            "the friction level falls with normal stress: a cohesive (or adhesive) shear "
            "strength c that does not grow with the load adds c / sigma to mu, where the "
            "nanoblock interface's mu0 = sigma_s / p is the same at every load (Amontons)",
            "a constant friction offset between runs at different normal loads, larger at "
            "the lower load, that no rate or state parameter removes",
            {"cohesion_ratio": "c / sigma at the runs' geometric-mean load"},
            "(none yet: a constant cohesive force c A beside the contacts' force)",
            {"time_series": RsfVariant("aging", cohesion=True)},
            "friction time series at two or more normal loads (runs with normal_force)",
            varies="normal_force",
            ranges={"cohesion_ratio": (0.0, 0.3)},
        ),
        Effect(
            "machine_stiffness",
            "the elastic stiffness of machine and sample differs from the stated calibration",
            "rise time to the peak and the overshoot after a step mismatched with D_c held",
            {"stiffness": "K/W [1/m], fitted"},
            "loading.stiffness",
            {"time_series": RsfVariant("aging", fit_stiffness=True)},
            "velocity steps with a stated stiffness (stiffness or stiffness_per_load)",
            ranges={"stiffness_ratio": (0.2, 5.0)},
        ),
        Effect(
            "unstable_sliding",
            "the spring-slider is unstable (K below (b - a) / D_c): the record holds "
            "stick-slip or slow-slip cycles that no smooth law can follow",
            "regular stress drops with a period in slip; residuals no smooth law reduces",
            {},
            "loading.stiffness below (b - a) W / D_c",
            detector="regular stress drops (count, size, period in slip) in a segment, with "
            "the base fit's K/W against (b - a) / D_c",
            needs="a friction time series sampled through the drops",
        ),
    )
}
"""Every catalogue entry, by id."""

VERDICTS = ("none", "unexplained")
"""The answers besides a catalogue id."""
