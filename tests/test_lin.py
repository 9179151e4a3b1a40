"""Lin & Kanellakopoulos (1996) adaptive backstepping (controllers/lin_kanellakopoulos.py): the derivation
against the paper's closed-loop error system (16)–(20) and Lyapunov derivative (22), and the behaviours of
Figs. 4–5 on the 8 cm bump (24)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from suspension_sim.config import load_scenario, parse_scenario
from suspension_sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
RHO, GAMMA_PLANT, THETA = 1e-7, 1.545e9, 4.515e13 * 3.35e-4
SENSORS = ([{"name": n, "type": n} for n in ("travel", "wheel_pos", "corner_body_vel", "wheel_vel")]
           + [{"name": n, "type": "actuator_state", "params": {"state": n}} for n in ("load_pressure", "spool_position")])


def test_symbolic_road_terms_match_the_paper():
    """R3 = −∂α2/∂x4·K_t/M_us equals d3 + n3·h3 of (17)–(18); R4 at φ ≡ 0 equals the paper's d4 (19) plus the
    θ̂ term of h4 (20); ∂α3/∂x5 has the structure of the paper's ω4 (14)."""
    import sympy as sp

    from suspension_sim.controllers.lin_kanellakopoulos import derivation

    d = derivation()
    s, e = d["sym"], d["expr"]
    Mb, Mus, Ka, Ca, Kt, A = (s[k] for k in ("Mb", "Mus", "Ka", "Ca", "Kt", "A"))
    rho, gam, eps, eps1, th = s["rho"], s["gam"], s["eps"], s["eps1"], s["th"]
    c1, c2, c3, b3, beta = s["c1"], s["c2"], s["c3"], s["b3"], s["beta"]
    eta = s["x1"] - s["x3"]
    n3 = rho * Mb * Kt / (A * Mus)
    h3 = -eps1 * s["P0"] - eps1 * s["P1"] * eta
    assert sp.simplify(e["R3"] - n3 * (Ca / Mb - eps) - n3 * h3) == 0
    mt = 1 / Mb + 1 / Mus
    d3 = n3 * (Ca / Mb - eps)
    d4 = (c1 + c2 + c3) * d3 / (rho * gam) + Kt * (Ka - mt * Ca ** 2 + eps * mt * Ca * Mb) / (A * Mus * gam)
    flat = {s["P0"]: 0, s["P1"]: 0, s["P2"]: 0, s["P3"]: 0}
    assert sp.simplify(e["R4"].subs(flat) - d4 - Kt * th / (Mus * gam)) == 0
    sigma4 = Ca / Mb - (eps + eps1 * s["P0"]) - eps1 * s["P1"] * eta
    cbar3 = c3 + c2 + c1 + b3 * h3 ** 2
    assert sp.simplify(sp.diff(e["alpha3"], s["x5"]) - (-cbar3 + beta + mt * Mb * sigma4) / gam) == 0


def _lyapunov_run(dt):
    """A 2 cm bump with the filter threshold lowered to 1 cm (so the nonlinear filter terms are active) and no
    spool end stop (saturation would break the identities); α underestimated by 10 % so θ̃ ≠ 0."""
    sc = parse_scenario({
        "road": {"type": "bump", "params": {"preset": "lin_kanellakopoulos", "height": 0.02}},
        "sensors": SENSORS,
        "actuator": {"type": "hydraulic", "params": {"spool_limit": None}},
        "controller": {"type": "lin_kanellakopoulos", "params": {"alpha": 0.9 * 4.515e13, "m1": 0.01, "eps1": 1.5}},
        "sim": {"duration": 0.8, "dt": dt, "control_dt": dt, "log_dt": dt},
        "outputs": {"plots": False},
    })
    ts = Simulation([sc]).run()[0].ts
    c, eps, eps1, b, G = 200.0, 1.5, 1.5, 0.01, 40.0
    t = ts.t.to_numpy()
    z = [ts[f"ctrl.z{i}"].to_numpy() for i in (1, 2, 3, 4)]
    rth = RHO * THETA - ts["ctrl.theta_hat"].to_numpy()  # ρ·θ̃
    r = ts.road.to_numpy()
    phi, h3, h4 = (ts[f"ctrl.{k}"].to_numpy() for k in ("phi", "h3", "h4"))
    R3, R4, w3, w4 = (ts[f"ctrl.{k}"].to_numpy() for k in ("R3", "R4", "omega3", "omega4"))
    V = 0.5 * sum(zi ** 2 for zi in z) + rth ** 2 / (2 * G)
    Vdot_22 = (-(c + eps + eps1 * phi) * z[0] ** 2 - c * z[1] ** 2 - c * z[2] ** 2 - c * z[3] ** 2
               + R3 * z[2] * r + R4 * z[3] * r - b * h3 ** 2 * z[2] ** 2 - b * h4 ** 2 * z[3] ** 2)
    k = 3.35e-4 / (RHO * 290.0)
    kap = RHO * GAMMA_PLANT
    rhs16 = [-(c + eps + eps1 * phi) * z[0] + z[1],
             -c * z[1] - z[0] + k * z[2],
             -c * z[2] - k * z[1] + kap * z[3] + R3 * r - b * h3 ** 2 * z[2] + rth * w3,
             -c * z[3] - kap * z[2] + R4 * r - b * h4 ** 2 * z[3] + rth * w4]
    win = (t > 0.45) & (t < 0.79)

    def rel(num, formula):  # forward differences: the command is held from each sample on
        d = np.diff(num) / np.diff(t)
        e = (d - formula[:-1])[win[:-1]]
        return float(np.sqrt(np.mean(e ** 2)) / np.sqrt(np.mean(d[win[:-1]] ** 2)))

    return rel(V, Vdot_22), [rel(z[i], rhs16[i]) for i in range(4)], float(np.max(phi))


def test_error_system_and_lyapunov_derivative_along_a_trajectory():
    v1, e1, phimax = _lyapunov_run(1e-4)
    v2, e2, _ = _lyapunov_run(2e-4)
    assert phimax > 1.0  # the nonlinear filter was active
    assert v1 < 0.05, v1  # (22) holds to within the sampled-data error
    assert max(e1) < 0.1, e1  # (16) holds equation by equation
    # the residuals are first-order sampling errors (halving the step halves them), not a derivation error
    assert 1.6 < v2 / v1 < 2.6
    for a, b in zip(e1, e2):
        assert 1.6 < b / a < 2.6


def _figure(fig, duration=1.2):
    sc = load_scenario(ROOT / f"scenarios/lin_fig{fig}.yaml")
    sc.sim.duration = duration
    sc.outputs.plots = False
    variants = dict(sc.expand())
    names = ["known", "adaptive", "nonadaptive"]
    res = Simulation([variants[n] for n in names]).run()
    return {n: r.ts for n, r in zip(names, res)}


@pytest.fixture(scope="module")
def fig4():
    return _figure(4)


@pytest.fixture(scope="module")
def fig5():
    return _figure(5)


def _dev(ts, ref):
    w = (ref.t >= 0.5) & (ref.t <= 0.8)
    return float(np.sqrt(np.mean(((ts.body_acc - ref.body_acc)[w]) ** 2)))


@pytest.mark.parametrize("fig", [4, 5])
def test_travel_inside_limits_and_adaptation_helps(fig, fig4, fig5):
    res = fig4 if fig == 4 else fig5
    for name, ts in res.items():
        # ±8 cm travel limit on the 8 cm bump: a limit check (the passive car stays inside too, 6.8 cm); the baseline
        # that fails it is the law without the nonlinear filter (ε1 = 0: 8.9 cm, test_filter_reading_…)
        assert np.max(np.abs(ts.travel)) < 0.08, name
        assert np.max(np.abs(ts["act.spool_position"])) <= 0.01 + 1e-12
    d_ad, d_non = _dev(res["adaptive"], res["known"]), _dev(res["nonadaptive"], res["known"])
    assert d_ad < 0.6 * d_non, (d_ad, d_non)


def test_estimate_moves_in_the_compensating_direction(fig4, fig5):
    # Fig. 4: α·A underestimated by 10 % -> the estimate rises towards the true ρ·α·A = 1512.5
    th = fig4["adaptive"]["ctrl.theta_hat"].to_numpy()
    assert th[0] == pytest.approx(0.9 * RHO * THETA)
    assert th[-1] > th[0] + 0.5 * (RHO * THETA - th[0])
    assert np.all(np.isfinite(th)) and th.max() < 1.2 * RHO * THETA
    # Fig. 5: γ overestimated by 10 %.  θ̂ enters the law only through the flow feed-forward θ̂·η̇/γ̂, so the
    # compensating direction is up (θ̂/γ̂ -> θ/γ means θ̂ -> 1.1·θ)
    th5 = fig5["adaptive"]["ctrl.theta_hat"].to_numpy()
    assert th5[0] == pytest.approx(RHO * THETA)
    assert th5[-1] > 1.03 * th5[0]
    assert fig5["nonadaptive"]["ctrl.theta_hat"].iloc[-1] == pytest.approx(RHO * THETA)


def test_scalar_and_array_evaluations_agree():
    """The controller evaluates the derived law with python floats for small ensembles and with numpy arrays
    for large ones: both compiled forms must give the same numbers."""
    from suspension_sim.controllers.lin_kanellakopoulos import _PARAM, _STATE, derivation

    d = derivation()
    rng = np.random.default_rng(3)
    state = {"x1": 0.03, "x2": 0.4, "x3": -0.01, "x4": 1.2, "x5": 2e6, "xb": 0.005, "P0": 2.0, "P1": 300.0,
             "P2": 2e4, "P3": 1e6, "th": 1.4e10, "S": 5.0, "Q": 1e-6}
    par = {"Mb": 290.0, "Mus": 59.0, "Ka": 16812.0, "Ca": 1000.0, "Kt": 190000.0, "A": 3.35e-4, "beta": 1.0,
           "gam": 1.545e9, "rho": 1e-7, "c1": 200.0, "c2": 200.0, "c3": 200.0, "c4": 200.0, "b3": 0.01,
           "b4": 0.01, "eps": 1.5, "eps1": 1.5, "Gam": 40.0}
    vals = [state[k] * (1 + 0.1 * rng.standard_normal()) for k in _STATE] + [par[k] for k in _PARAM]
    a = np.array(d["f_math"](*vals), dtype=float)
    b = np.array([float(np.asarray(v).flat[0]) for v in d["f_numpy"](*[np.full((2, 1), v) for v in vals])])
    assert np.all(np.isfinite(a))
    assert np.allclose(a, b, rtol=1e-9, atol=1e-12)


def test_filter_reading_keeps_the_known_run_inside_the_papers_axes():
    """Eq. (25) prints one unsubscripted filter constant (ε = 1.5); ε1 is reconstructed (0.01 1/s).  With it the
    known-parameter run of Fig. 2 stays inside the paper's axes (body acc −9…12 m/s², body travel ≤ 0.025 m,
    load pressure −1e7…5e6 Pa) with the travel inside its ±8 cm limit.  Baselines that must fail: the earlier
    reading ε1 = ε = 1.5 (a spike of tens of m/s² when the travel passes m1 = 5.5 cm, the body rises beyond the
    axis) and no nonlinear filter at all (ε1 = 0: the travel passes ±8 cm)."""
    sc = load_scenario(ROOT / "scenarios/lin_fig2.yaml")
    known = dict(sc.expand())["known"]
    known.sim.duration = 1.5
    known.sim.log_dt = 1e-4
    assert known.controller.params["eps"] == 1.5 and known.controller.params["eps1"] == 0.01
    earlier, plain = known.model_copy(deep=True), known.model_copy(deep=True)
    earlier.controller.params["eps1"] = 1.5
    plain.controller.params["eps1"] = 0.0
    ts, ts1, ts0 = (r.ts for r in Simulation([known, earlier, plain]).run())

    def inside(t):
        a, P = t.body_acc.to_numpy(), t["act.load_pressure"].to_numpy()
        return (a.min() >= -9 and a.max() <= 12 and t.body_z.max() <= 0.025 and P.min() >= -1e7 and P.max() <= 5e6
                and np.max(np.abs(t.travel)) < 0.08)

    assert inside(ts)
    assert not inside(ts1) and not inside(ts0)
    a1 = ts1.body_acc.to_numpy()
    i = int(np.argmax(np.abs(a1)))
    assert a1[i] > 40 and abs(abs(ts1.travel.to_numpy()[i]) - 0.055) < 0.008  # the spike, at the threshold
    assert np.max(np.abs(ts0.travel)) > 0.08


def test_adaptive_run_approaches_the_known_run_as_the_estimate_converges():
    """Figs. 4–5 continued (item ``repeat`` of ``reproduce lin``): the bump (24) three times, 2.5 s apart.  The
    paper's claim, "adaptive close to known, non-adaptive deviates", judged bump by bump: once θ̂ has converged
    (Fig. 4: 1361 → 1502 of 1512.5 before the third bump) the adaptive run's deviation from the known-parameter run
    is less than half that of the first bump and less than half the non-adaptive run's, while the non-adaptive
    baseline (the same wrong value, no update) does not improve from bump to bump.  Run at 0.05 ms (the item's
    0.0125 ms gives the same numbers within 1 %: 3.11 → 1.38 m/s² against 6.8)."""
    sc = load_scenario(ROOT / "scenarios/lin_fig4.yaml", ["sim.duration=6.5", "road.params.repeat=3",
                                                          "road.params.period=2.5", "sim.dt=5e-5",
                                                          "sim.control_dt=5e-5", "outputs.plots=false"])
    v = dict(sc.expand())
    names = ("known", "adaptive", "nonadaptive")
    res = {n: r.ts for n, r in zip(names, Simulation([v[n] for n in names]).run())}
    k = res["known"]
    dev = {n: [] for n in names[1:]}
    for a in (0.5, 3.0, 5.5):
        w = ((k.t >= a) & (k.t <= a + 0.3)).to_numpy()
        for n in dev:
            dev[n].append(float(np.sqrt(np.mean(((res[n].body_acc - k.body_acc).to_numpy()[w]) ** 2))))
    ad, na = dev["adaptive"], dev["nonadaptive"]
    assert ad[2] < 0.5 * ad[0], ad
    assert ad[2] < 0.5 * na[2], (ad, na)
    assert na[2] > 0.9 * na[0], na  # the baseline does not approach the known run
    th = res["adaptive"]["ctrl.theta_hat"].to_numpy()
    assert abs(th[-1] / (RHO * THETA) - 1) < 0.02


def _j(ts, a, b):
    m = ((ts.t >= a) & (ts.t <= b)).to_numpy()
    return float(np.sqrt(np.mean(ts.body_acc.to_numpy()[m] ** 2)))


def test_fig2_and_fig3_robustness_claims_with_a_metric_that_can_fail():
    """Figs. 2–3 (non-adaptive law, wrong controller values).  Fig. 2: with M_b, K_a ±20 % the three curves "almost
    overlap": RMS body acceleration over 0.5–1.5 s within 5 % of the known run (measured 3.5 %); the same metric
    flags an error the paper calls much worse (α −10 %: measured +123 % in Table 1), so it is not vacuous.
    Fig. 3: the "s.b." set is better than the known run and the "s.w." set worse, by more than 1 % over the bump
    (measured −5.6 % and +43.5 %); the known run itself is the baseline neither better nor worse.  Run at 0.05 ms
    (the page's 0.025 ms gives the same within 0.2 %)."""
    fast = ["sim.duration=1.5", "sim.dt=5e-5", "sim.control_dt=5e-5", "outputs.plots=false"]
    v2 = dict(load_scenario(ROOT / "scenarios/lin_fig2.yaml", fast).expand())
    v3 = dict(load_scenario(ROOT / "scenarios/lin_fig3.yaml", fast).expand())
    wrong_alpha = v2["known"].model_copy(deep=True)
    wrong_alpha.controller.params["alpha"] = 0.9 * 4.515e13
    runs = {"known": v2["known"], "mb_plus": v2["mb_plus_ka_minus"], "mb_minus": v2["mb_minus_ka_plus"],
            "alpha_minus": wrong_alpha, "better": v3["better"], "worse": v3["worse"]}
    res = {k: r.ts for k, r in zip(runs, Simulation(list(runs.values())).run())}
    J = {k: _j(ts, 0.5, 1.5) for k, ts in res.items()}
    assert max(abs(J[k] / J["known"] - 1) for k in ("mb_plus", "mb_minus")) < 0.05, J
    assert J["alpha_minus"] / J["known"] - 1 > 0.20, J  # the metric can fail
    Jb = {k: _j(res[k], 0.5, 0.8) for k in ("known", "better", "worse")}
    assert Jb["better"] < 0.99 * Jb["known"] < Jb["known"] < Jb["worse"] / 1.01, Jb


def test_table1_robust_to_mechanical_errors_not_to_the_hydraulic_ones_and_passive_fails():
    """Table 1 as we reproduce it (item ``table1`` of ``reproduce lin``; non-adaptive law, one controller value wrong
    at a time).  Property: a 20 % error in any of M_b, M_us, K_a, C_a, K_t, τ, β leaves J (RMS body acceleration
    0.5–1.5 s) within 20 % of the correct-value run J0 (our m.w. line; worst M_us −20 %: +15.5 %) and below the
    passive car's J, with the travel inside ±8 cm; the under-compensating errors in the hydraulic parameters
    (A −10 %, α −10 %, γ +10 %) make it much worse (> +20 %; measured +123…+141 %), worse even than passive.
    Baseline that must fail the first part: the passive car (no actuator) on the same bump, J0 + 39 %.  Run at
    0.05 ms (the page's 0.0125 ms gives every ΔJ here within 0.1 points except A −10 %, +131 % against +167 %)."""
    fast = ["sim.duration=1.5", "sim.dt=5e-5", "sim.control_dt=5e-5", "outputs.plots=false"]
    base = dict(load_scenario(ROOT / "scenarios/lin_fig2.yaml", fast).expand())["known"]
    from suspension_sim.config import read_yaml
    from suspension_sim.reproductions.lin import NOMINAL

    robust = {f"{k} {s:+d}%": {k: NOMINAL[k] * (1 + s / 100)} for k in
              ("sprung_mass", "unsprung_mass", "spring_stiffness", "damping", "tire_stiffness", "spool_time_constant",
               "beta") for s in (20, -20)}
    hydraulic = {"area -10%": {"area": 0.9 * NOMINAL["area"]}, "alpha -10%": {"alpha": 0.9 * NOMINAL["alpha"]},
                 "gamma +10%": {"gamma": 1.1 * NOMINAL["gamma"]}}
    cases = {"nominal": {}, **robust, **hydraulic}
    scs = []
    for p in cases.values():
        sc = base.model_copy(deep=True)
        sc.controller.params.update({**NOMINAL, "adaptive": False, **p})
        scs.append(sc)
    res = {k: r.ts for k, r in zip(cases, Simulation(scs).run())}
    raw = read_yaml(ROOT / "scenarios/lin_fig2.yaml")
    passive = parse_scenario({**raw, "variants": {}, "controller": {"type": "passive"}, "actuator": {"type": "ideal"},
                              "sensors": [], "outputs": {"plots": False},
                              "sim": {**raw["sim"], "duration": 1.5, "dt": 5e-5, "control_dt": 5e-5}})
    J = {k: _j(ts, 0.5, 1.5) for k, ts in res.items()}
    J["passive"] = _j(Simulation([passive]).run()[0].ts, 0.5, 1.5)
    dJ = {k: J[k] / J["nominal"] - 1 for k in J}
    for k in robust:
        assert abs(dJ[k]) < 0.20 and J[k] < J["passive"], (k, dJ)
        assert np.max(np.abs(res[k].travel)) < 0.08, k
    assert max(abs(dJ[k]) for k in robust) > 0.10, dJ  # some of them do matter (M_us −20 %, K_t +20 %)
    for k in hydraulic:
        assert dJ[k] > 0.20 and J[k] > J["passive"], (k, dJ)
    assert dJ["passive"] > 0.20, dJ  # the baseline fails: without the controller J is far from J0
