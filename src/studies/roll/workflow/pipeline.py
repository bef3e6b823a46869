"""Roll-decay study: identify, validate, compare with a simulation, write the outputs.

One entry point for the command line, :func:`run_roll_study`; plus
:func:`compare_methods` (Chen et al. 2019, Table 6 and Fig. 8). The roll
domain itself (model, estimators, records, simulation, decay analysis,
figures) is :mod:`studies.roll`.

Outputs written into ``out_dir`` (the output contract of DESIGN.md):

- ``coefficients.csv``: ``name,value,lower,upper,true,deviation_pct``
  (``lower``/``upper``: the 5 and 95 % posterior quantiles of
  ``method=bayes``, whose ``value`` is the posterior median; empty for NLS,
  FLS and NLS-SVM, which give no posterior);
- ``metrics.json``: flat numbers (CPU time, equivalent damping,
  dimensional coefficients, simulation-vs-test numbers) and the prediction
  errors of every record, computed one way for every method
  (:func:`studies.roll.comparison.replay_errors`: the identified model
  simulated over the whole record, MAE and RMSE in degrees, eq. 17-18) from
  two initial states, named in the key:

  - ``<stem>/mae_deg_record_start``, ``<stem>/rmse_deg_record_start``: from
    the record's own initial state (angle and rate fitted to its first
    period; ``<stem>/phi0_deg_record_start``, ``rate0_deg_s_record_start``),
    the same for every method: the like-for-like comparison;
  - ``<stem>/mae_deg_own_start``, ``<stem>/rmse_deg_own_start`` (training
    records): from the method's own estimate of the initial state
    (``<stem>/phi0_deg_own_start``, ``rate0_deg_s_own_start``): NLS fits it
    with the coefficients, FLS and NLS-SVM take their curve fit's value at
    the first sample;
  - ``<stem>/diverged_record_start``, ``<stem>/diverged_own_start``: 1 when
    that replay left +-90 deg (its errors are then not written);
    ``fit/`` and ``validation/rmse_deg_record_start|own_start`` pool the
    records whose replay stayed bounded, ``fit/diverged_*`` count the others;
  - ``<stem>/rmse_deg_record_start_linear_only`` (and ``mae``): the same
    for a linear-only model (``b1``) identified by the same method;
- PNG figures: predictions and errors per record (paper Figs 5/8), decay
  curves, and the simulation-vs-test comparison;
- with ``method=bayes``: ``bayes/roll/...`` convergence metrics (acceptance
  fraction, autocorrelation time, converged) and ``metric_history.json``,
  ``corner_roll.png``, ``discrepancy/...`` (``method.discrepancy=process_noise``)
  and, per validation record (another record, or the held-out later cycles
  of one decay with ``holdout``), the posterior predictive bands of the
  decay and of its peak envelope (:mod:`studies.roll.bands`):
  ``<stem>/band/coverage_50|80|90|95``, ``covered_until_s``,
  ``width_deg``, ``width_over_amplitude``, ``interval_score_deg``,
  ``crps_deg``, ``envelope_coverage_...``, ``envelope_width_deg``, ...,
  ``outside_training`` and ``trusted``; ``validation/bands_trusted``;
  ``band_<stem>.png``/``.csv``, ``calibration_<stem>.png`` and ``bands.md``
  (whether the bands can be trusted, record by record).

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from studies.analysis.bands import TRUSTED_COVERAGE, plot_calibration
from studies.errors import ConfigError
from studies.identification.bayes.figures import CORNER_MAX, plot_corner
from studies.roll.bands import (BAND_KEYS, band_statistics, band_table, outside_amplitudes, plot_band,
                                predictive_replays, trust_verdict)
from studies.roll.comparison import STARTS, compare_simulation_with_tests, mae, replay_errors, rmse
from studies.roll.decay import decay_curve, noise_std
from studies.roll.figures import plot_decay_curves, plot_prediction
from studies.roll.methods import make_method
from studies.workflows.methods import check_method
from studies.roll.model import (
    OPTIONAL_TERMS,
    damping_ratio,
    dimensional_coefficients,
    equivalent_linear_damping,
    froude_scale_params,
)
from studies.roll.records import froude_scale_record, initial_state, load_roll_decay, split_cycles

__all__ = ["run_roll_study", "compare_methods"]

#: the methods of Chen et al. (2019) compared by :func:`compare_methods`
METHODS = ("nls", "fls", "nls_svm")
#: the file of the identification's step metrics (emcee's acceptance and autocorrelation time)
METRIC_HISTORY = "metric_history.json"
COEFFICIENT_COLUMNS = ["name", "value", "lower", "upper", "true", "deviation_pct"]


# --------------------------------------------------------------- helpers
def _load(x) -> pd.DataFrame:
    if isinstance(x, pd.DataFrame):
        return x
    return load_roll_decay(x)


def _as_list(paths) -> list:
    if paths is None:
        return []
    if isinstance(paths, (str, Path, pd.DataFrame)):
        return [paths]
    return list(paths)


def _stem(rec: pd.DataFrame, i: int) -> str:
    return str(rec.attrs.get("name") or f"record_{i}")


def _check_method_terms(method: str, terms: Sequence[str]) -> tuple[str, ...]:
    check_method("roll_decay", method)
    terms = tuple(terms)
    bad = [t for t in terms if t not in OPTIONAL_TERMS]
    if bad:
        raise ConfigError(f"terms={list(terms)}: unknown roll term(s) {bad}; choose from {list(OPTIONAL_TERMS)}")
    if not any(t in ("b1", "b2", "b3") for t in terms):
        raise ConfigError(f"terms={list(terms)}: the roll model needs at least one damping term (b1, b2, b3)")
    return terms


def _particulars(records: Sequence[pd.DataFrame]) -> dict | None:
    for r in records:
        p = r.attrs.get("particulars")
        if p:
            return p
    return None


def _dimensional_metrics(params: Mapping[str, float], part: dict, amplitude: float) -> dict[str, float]:
    """Dimensional coefficients at full and model scale from Froude-scaled params."""
    lam = float(part["scale"])
    f = part["full"]
    out: dict[str, float] = {"dimensional/scale_factor": lam}
    full = froude_scale_params(params, lam, "full")
    units = {"C44": "Nm", "I_total": "kgm2", "B44": "kgm2_s", "B44q": "kgm2", "B44c": "kgm2s",
             "C44c": "Nm", "I_xx": "kgm2", "A44": "kgm2", "A44_ratio": "-"}
    for tag, p, V, gm, kxx in (
        ("full", full, f["displacement"], f["gm"], f["kxx"]),
        ("model", params, f["displacement"] / lam**3, f["gm"] / lam, f["kxx"] / lam),
    ):
        d = dimensional_coefficients(p, V, gm, kxx, rho=f["rho"], g=f["g"])
        for k, v in d.items():
            u = units.get(k, "")
            key = f"dimensional/{k}_{tag}" + (f"_{u}" if u and u != "-" else "")
            out[key] = float(v)
        beq = equivalent_linear_damping(p, amplitude)
        out[f"dimensional/B44_eq_{tag}_kgm2_s"] = float(beq * d["I_total"])
    out["dimensional/omega0_full_rad_s"] = float(full["omega0"])
    out["dimensional/T0_full_s"] = 2 * math.pi / float(full["omega0"])
    return out


def _clean(metrics: Mapping[str, float]) -> dict[str, float]:
    out = {}
    for k, v in metrics.items():
        try:
            x = float(v)
        except (TypeError, ValueError):
            continue
        if math.isfinite(x):
            out[k] = x
    return dict(sorted(out.items()))


def _own_start(fit, index: int | None):
    """The method's own initial state of training record ``index`` (None: not a training record)."""
    states = fit.meta.get("initial_states") or []
    if index is None or index >= len(states):
        return None
    return tuple(float(v) for v in states[index])


def _replays(fit, terms, rec, own) -> dict:
    """``{start: ReplayErrors}`` of one record: from the record's initial state
    and, when ``own`` is given, from the method's own."""
    out = {"record_start": replay_errors(fit.params, terms, rec, initial_state(rec))}
    if own is not None:
        out["own_start"] = replay_errors(fit.params, terms, rec, own)
    return out


def _replay_metrics(stem: str, replays: dict) -> dict[str, float]:
    """The metrics of :func:`_replays`: errors [deg] of bounded replays, the
    diverged flag and the start of each."""
    m: dict[str, float] = {}
    for start, e in replays.items():
        m[f"{stem}/diverged_{start}"] = float(e.diverged)
        m[f"{stem}/phi0_deg_{start}"] = math.degrees(e.start[0])
        m[f"{stem}/rate0_deg_s_{start}"] = math.degrees(e.start[1])
        if not e.diverged:
            m[f"{stem}/mae_deg_{start}"] = math.degrees(e.mae)
            m[f"{stem}/rmse_deg_{start}"] = math.degrees(e.rmse)
    return m


def _condition_metrics(stem: str, rec: pd.DataFrame) -> dict[str, float]:
    """What the record says of its test: forward speed [m/s at its scale and
    kn at full scale] and the scale factor, when known."""
    m: dict[str, float] = {}
    part = rec.attrs.get("particulars") or {}
    if rec.attrs.get("speed") is not None:
        m[f"{stem}/speed_m_s"] = float(rec.attrs["speed"])
    if part.get("speed_kn") is not None:
        m[f"{stem}/speed_kn_full_scale"] = float(part["speed_kn"])
    if part.get("scale") is not None:
        m[f"{stem}/scale_factor"] = float(part["scale"])
    return m


def _decay_metrics(stem: str, rec: pd.DataFrame, n: int = 4) -> dict[str, float]:
    """What the record's decay curve says: noise, and period and amplitude over
    its first and last ``n`` half-cycles (a period that changes with amplitude
    is what a model with one omega0 cannot follow)."""
    curve = decay_curve(rec)
    m = {f"{stem}/noise_deg": math.degrees(noise_std(rec["phi"].to_numpy(float))),
         f"{stem}/n_half_cycles": float(len(curve))}
    if len(curve) >= 2 * n:
        for tag, part in (("first", curve.iloc[:n]), ("last", curve.iloc[-n:])):
            m[f"{stem}/period_{tag}_s"] = 2.0 * float(part["half_period"].mean())
            m[f"{stem}/amplitude_{tag}_deg"] = math.degrees(float(part["amplitude"].mean()))
    return m


def _posterior_outputs(fit, terms, train, valid, out: Path, m: dict, band_draws: int, seed: int,
                       corner_max: int, method: str) -> list[str]:
    """The outputs of a posterior (``method=bayes``): corner plot, step
    metrics, and the predictive bands of every validation record with their
    metrics (into ``m``), figures, tables and ``bands.md``."""
    samples = fit.meta.get("samples")
    if not samples:
        return []
    files = []
    path = out / "corner_roll.png"
    plot_corner(samples["names"], samples["values"], path, f"{method}: posterior of the roll coefficients",
                max_params=corner_max)
    files.append(str(path))
    history = fit.meta.get("history") or {}
    if history:
        path = out / METRIC_HISTORY
        path.write_text(json.dumps({k: [[int(step), float(value)] for step, value in v]
                                    for k, v in sorted(history.items())}, indent=1))
        files.append(str(path))
    if band_draws <= 0 or not valid:
        return files
    disc = fit.meta.get("discrepancy")
    what = "coefficients and model discrepancy" if disc is not None else "coefficients"
    verdicts, trusted_all = [], []
    for i, rec in enumerate(valid):
        stem = _stem(rec, len(train) + i)
        replays, diverged = predictive_replays(samples["values"], samples["names"], terms, rec, band_draws,
                                               disc, seed + 1000 + i)
        stats = band_statistics(replays, diverged, rec, seed=seed + 1000 + i)
        for key in BAND_KEYS:
            m[f"{stem}/band/{key}"] = stats[key]
        outside, train_range, rec_range = outside_amplitudes(rec, train)
        trusted, sentence = trust_verdict(stem, stats, outside, train_range, rec_range)
        m[f"{stem}/band/draws"] = float(band_draws)
        m[f"{stem}/band/discrepancy"] = float(disc is not None)
        m[f"{stem}/band/outside_training"] = outside
        m[f"{stem}/band/trusted"] = float(trusted)
        verdicts.append(sentence)
        trusted_all.append(float(trusted))
        fig = out / f"band_{stem}.png"
        plot_band(rec, stats, fig, f"{stem}: 5-95 % posterior predictive band ({band_draws} replays: {what})")
        cal = out / f"calibration_{stem}.png"
        plot_calibration(stats, cal, f"{stem}\ncoverage of the measured decay ({what})",
                         series=(("coverage", "roll angle inside"), ("envelope_coverage", "peak envelope inside")))
        table = out / f"band_{stem}.csv"
        band_table(stats).to_csv(table, index=False)
        files += [str(fig), str(cal), str(table)]
    m["validation/bands_trusted"] = float(np.mean(trusted_all))
    path = out / "bands.md"
    path.write_text(_bands_markdown(verdicts, disc, fit.params))
    files.append(str(path))
    return files


def _bands_markdown(verdicts: list, discrepancy, params: Mapping[str, float]) -> str:
    """``bands.md``: whether the predictive bands of the decays can be trusted, record by record."""
    if discrepancy is None:
        source = ("The bands come from the coefficient posterior alone (`method.discrepancy=none`): the "
                  "model is taken as exact, so they hold only the coefficients' and the initial state's "
                  "uncertainty and the measurement noise.")
    else:
        source = (f"The bands come from the coefficient posterior and a model discrepancy "
                  f"(`method.discrepancy={discrepancy.kind}`): {discrepancy.describe(params)}, estimated "
                  f"on the training decays only.")
    lo, hi = TRUSTED_COVERAGE
    lines = ["# Predictive bands of the roll decays", "", source, "",
             f"A band is trusted on a record when its 90 % band holds the measured roll angle between "
             f"{100 * lo:.0f} and {100 * hi:.0f} % of the time, is narrower than the record's amplitude "
             "and fewer than 10 % of the replays diverge (figures `calibration_<record>.png`: coverage "
             "of the angle and of the peak envelope against the nominal 50/80/90/95 %; "
             "`band_<record>.png`: the bands).", ""]
    lines += [f"- {v}" for v in verdicts]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------ entry point
def run_roll_study(data_paths: list[str], method: str, out_dir: str,
                   validate_paths: list[str] | None = None, terms: list[str] = ["b1", "b2"],  # noqa: B006
                   simulation_path: str | None = None, true_params: dict | None = None,
                   seed: int = 0, method_settings: dict | None = None, band_draws: int = 50,
                   holdout: float | None = None,
                   corner_max: int = CORNER_MAX) -> tuple[pd.DataFrame, dict[str, float], list[str]]:
    """Identify a roll-decay model, validate it and write the study outputs.

    Parameters
    ----------
    data_paths : list of str
        Decay records identified on (jointly when several): data-contract
        CSVs (``t``, ``phi``), SSPA model tests (``time``, ``phi``) or the
        FNPF format (``Time``, ``phi``); see :mod:`studies.roll.records`.
    method : {"nls", "fls", "nls_svm", "bayes"}
        Identification method (:mod:`studies.roll.methods`).
    out_dir : str
        Directory for ``coefficients.csv``, ``metrics.json`` and figures
        (created; nothing is written when an input is refused).
    validate_paths : list of str, optional
        Records predicted by simulation from their initial state with the
        identified model (and with a linear-only model, ``b1`` only,
        identified by the same method on the same data).
    terms : list of str
        Model terms, default ``["b1", "b2"]``; any of ``b1, b2, b3, c3``.
    simulation_path : str, optional
        A simulated decay of the same ship (e.g. the FNPF potential-flow
        record) compared with the measured records: decay curves, equivalent
        linear damping, missing damping.
    true_params : dict, optional
        Known coefficients (simulated data): fills ``true`` and
        ``deviation_pct`` = 100 (value - true) / true.
    seed : int
        Seed passed to the estimator (NLS, FLS and NLS-SVM are deterministic;
        emcee's draws and the bands' replays of ``bayes``).
    method_settings : dict, optional
        Settings of the method's estimator (``bayes``: sampler and
        discrepancy, :class:`studies.roll.bayes.BayesRollEstimator`).
    band_draws : int
        Replays of every validation record for its predictive band
        (``bayes``); 0: no bands.
    holdout : float, optional
        With one training record and no ``validate_paths``: the share of its
        half-cycles (the last ones) held out as a validation record
        (:func:`studies.roll.records.split_cycles`), predicted from its own
        initial state.
    corner_max : int
        At most this many coefficients in ``corner_roll.png``.

    Returns
    -------
    coefficients : DataFrame
        Columns ``name,value,lower,upper,true,deviation_pct``.
    metrics : dict
        Flat ``{name: float}``, as written to ``metrics.json``.
    files : list of str
        Paths written.

    Raises
    ------
    studies.errors.DataError
        A record that is not a roll decay (the message names the file).
    studies.errors.ConfigError
        Unknown method or term.

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479 (Tables 5-6, Figs 5 and 8).
    """
    terms = _check_method_terms(method, terms)
    train_in = _as_list(data_paths)
    if not train_in:
        raise ConfigError("data.path: no roll-decay record given")
    # load (and refuse) every input before anything is written
    train = [_load(p) for p in train_in]
    valid = [_load(p) for p in _as_list(validate_paths)]
    sim = _load(simulation_path) if simulation_path is not None else None
    held_out = None
    if holdout is not None and len(train) == 1 and not valid:
        try:
            first, last = split_cycles(train[0], float(holdout))
        except ValueError as exc:
            raise ConfigError(f"model.holdout={holdout:g}: {exc}") from None
        train, valid, held_out = [first], [last], float(last.attrs["t_from_release"])

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files: list[str] = []

    settings = dict(method_settings or {})
    method_seed = int(settings.pop("seed", seed))  # method.seed, ${seed} unless set apart
    fit = make_method(method, terms, method_seed, **settings).fit(train)
    lin_terms = ("b1",)
    # the linear-only model by the same method; its posterior needs no discrepancy
    lin_settings = {**settings, "discrepancy": "none"} if "discrepancy" in settings else settings
    lin = fit if terms == lin_terms else make_method(method, lin_terms, method_seed, **lin_settings).fit(train)

    # ---------------------------------------------------- coefficients.csv
    rows = []
    for name in ("omega0",) + terms:
        v = fit.params[name]
        tv = float(true_params[name]) if true_params and name in true_params else np.nan
        dev = 100.0 * (v - tv) / tv if np.isfinite(tv) and tv != 0 else np.nan
        rows.append({"name": name, "value": v, "lower": fit.meta.get("lower", {}).get(name, np.nan),
                     "upper": fit.meta.get("upper", {}).get(name, np.nan), "true": tv,
                     "deviation_pct": dev})
    coeffs = pd.DataFrame(rows, columns=COEFFICIENT_COLUMNS)
    p_csv = out / "coefficients.csv"
    coeffs.to_csv(p_csv, index=False)
    files.append(str(p_csv))

    # ------------------------------------------------------------ metrics
    m: dict[str, float] = {
        "cpu_s": fit.cpu_s,
        "wall_s": fit.meta.get("wall_s", np.nan),
        "cpu_s_linear_only": lin.cpu_s,
        "n_training_records": len(train),
        "n_validation_records": len(valid),
        "seed": seed,
    }
    for k, v in fit.params.items():
        m[f"coef/{k}"] = v
    for k, v in lin.params.items():
        m[f"coef_linear_only/{k}"] = v
    for key in ("sigma_s", "sigma_periods", "gamma", "cv_mse", "smoothing_lam", "residual_rms",
                "offset_rad", "nfev"):
        if key in fit.meta and np.isscalar(fit.meta[key]):
            m[f"method/{key}"] = fit.meta[key]
    if true_params:
        for _, r in coeffs.iterrows():
            if np.isfinite(r["deviation_pct"]):
                m[f"deviation_pct/{r['name']}"] = r["deviation_pct"]
            if np.isfinite(r["lower"]) and np.isfinite(r["true"]):
                m[f"covered_90/{r['name']}"] = float(r["lower"] <= r["true"] <= r["upper"])
    m.update(fit.meta.get("metrics", {}))
    if held_out is not None:
        m["holdout/share"] = float(holdout)
        m["holdout/t_from_release_s"] = held_out

    a_ref = abs(float(train[0]["phi"].iloc[0]))
    m["equivalent/amplitude_deg"] = math.degrees(a_ref)
    m["equivalent/b_eq_1_s"] = equivalent_linear_damping(fit.params, a_ref)
    m["equivalent/zeta_eq"] = damping_ratio(fit.params, a_ref)
    m["equivalent/zeta_linear_part"] = fit.params.get("b1", 0.0) / (2 * fit.params["omega0"])
    m["equivalent/zeta_linear_only_model"] = damping_ratio(lin.params, a_ref)
    if "b2" in fit.params:
        beq = equivalent_linear_damping(fit.params, a_ref)
        m["equivalent/quadratic_share_at_release"] = (
            8.0 / (3.0 * math.pi) * fit.params["omega0"] * a_ref * fit.params["b2"] / beq if beq else np.nan)
    for a_deg in (2.0, 5.0, 10.0):
        m[f"equivalent/zeta_eq_at_{a_deg:g}deg"] = damping_ratio(fit.params, math.radians(a_deg))
    part = _particulars(train)
    if part is not None:
        m.update(_dimensional_metrics(fit.params, part, a_ref))

    pooled = {(group, start): [0.0, 0, 0] for group in ("fit", "validation") for start in STARTS}
    names_seen: dict[str, int] = {}
    for i, (rec, is_train) in enumerate([(r, 1) for r in train] + [(r, 0) for r in valid]):
        stem = _stem(rec, i)
        if stem in names_seen:  # the same file given twice
            names_seen[stem] += 1
            stem = f"{stem}_{names_seen[stem]}"
        else:
            names_seen[stem] = 0
        replays = _replays(fit, terms, rec, _own_start(fit, i) if is_train else None)
        linear = replay_errors(lin.params, lin_terms, rec, initial_state(rec))
        m.update(_replay_metrics(stem, replays))
        if not linear.diverged:
            m[f"{stem}/rmse_deg_record_start_linear_only"] = math.degrees(linear.rmse)
            m[f"{stem}/mae_deg_record_start_linear_only"] = math.degrees(linear.mae)
        m[f"{stem}/is_training"] = is_train
        m[f"{stem}/duration_s"] = float(rec["t"].iloc[-1])
        m[f"{stem}/release_amplitude_deg"] = math.degrees(abs(float(rec["phi"].iloc[0])))
        m.update(_decay_metrics(stem, rec))
        m.update(_condition_metrics(stem, rec))
        group = "fit" if is_train else "validation"
        for start, e in replays.items():
            cell = pooled[(group, start)]
            if e.diverged:
                cell[2] += 1
            else:
                cell[0] += e.rmse**2 * len(rec)
                cell[1] += len(rec)
        if is_train == 0 or not valid:
            label = "+".join(terms)
            predictions = {f"{method} ({label})": replays["record_start"].predicted}
            if "own_start" in replays:
                predictions[f"{method} ({label}), own start"] = replays["own_start"].predicted
            predictions[f"{method} (b1 only)"] = linear.predicted
            fig = out / f"prediction_{stem}.png"
            plot_prediction(rec["t"], rec["phi"], predictions, str(fig),
                            title=f"{stem}: measured and predicted roll ({'fitted' if is_train else 'not fitted'})")
            files.append(str(fig))
    for (group, start), (sq, n, diverged) in pooled.items():
        if group == "validation" and (not valid or start == "own_start"):
            continue  # no validation records; their own start exists only for fitted ones
        m[f"{group}/diverged_{start}"] = float(diverged)
        if n:
            m[f"{group}/rmse_deg_{start}"] = math.degrees(math.sqrt(sq / n))

    files += _posterior_outputs(fit, terms, train, valid, out, m, band_draws, seed, corner_max, method)

    curves = {_stem(r, i): decay_curve(r) for i, r in enumerate(train + valid)}
    fig = out / "decay_curves.png"
    plot_decay_curves(curves, str(fig), models={f"{method} ({'+'.join(terms)})": fit.params,
                                                f"{method} (b1 only)": lin.params},
                      title="decay curves: measured half-cycles and identified models")
    files.append(str(fig))

    # ------------------------------------------ simulation vs measurement
    if sim is not None:
        tests = train + valid
        sim_part = sim.attrs.get("particulars") or {}
        test_scale = float((part or {}).get("scale", 1.0))
        sim_scale = float(sim_part.get("scale", test_scale))
        sim_c = froude_scale_record(sim, sim_scale, test_scale) if sim_scale != test_scale else sim
        t_meas = float(np.median([r.attrs.get("period", np.nan) for r in tests]))
        m["simulation/scale_factor_file"] = sim_scale
        m["simulation/scale_factor_compared"] = test_scale
        m["simulation/period_ratio_to_tests"] = float(sim_c.attrs.get("period", np.nan)) / t_meas
        inertia = None
        if part is not None:
            # total inertia at full scale from the identified natural frequency
            full = froude_scale_params(fit.params, test_scale, "full")
            f = part["full"]
            inertia = dimensional_coefficients(full, f["displacement"], f["gm"], rho=f["rho"], g=f["g"])["I_total"]
        scale_note = "model scale 1:%g" % test_scale if test_scale != 1 else "full scale"
        fig = out / "simulation_vs_tests.png"
        cm, _ = compare_simulation_with_tests(sim_c, tests, terms=("b1", "b2"), scale_note=scale_note,
                                              figure_path=str(fig), labels=[_stem(r, i) for i, r in enumerate(tests)])
        files.append(str(fig))
        m.update(cm)
        if inertia is not None:
            w_full = float(cm["measured/decay_curve_omega0"]) / math.sqrt(test_scale)
            m["simulation/missing_B44_eq_full_kgm2_s"] = 2.0 * w_full * inertia * cm["simulation/missing_zeta"]

    metrics = _clean(m)
    p_json = out / "metrics.json"
    p_json.write_text(json.dumps(metrics, indent=1))
    files.append(str(p_json))
    return coeffs, metrics, files


# ---------------------------------------------------------- comparison
def compare_methods(data_paths, validate_paths=None, terms: Sequence[str] = ("b1", "b2"),
                    methods: Sequence[str] = METHODS, out_dir: str | None = None,
                    seed: int = 0) -> pd.DataFrame:
    """Table-6-style comparison of NLS, FLS and NLS-SVM on the same records.

    Every method's errors are computed the same way
    (:func:`studies.roll.comparison.replay_errors`), from two initial states
    (:data:`studies.roll.comparison.STARTS`), each named in its row:
    ``record_start`` (the record's own initial state, the same for every
    method: like for like) and ``own_start`` (the method's own estimate:
    NLS fits it with the coefficients, FLS and NLS-SVM take their curve
    fit's value at the first sample; only when the errors are computed on
    the identification records themselves).

    Parameters
    ----------
    data_paths : path, DataFrame or list of them
        Records identified on.
    validate_paths : path, DataFrame or list of them, optional
        Records on which MAE and RMSE are computed; default the
        identification records themselves, as in the paper.
    terms : sequence of str
        Model terms.
    methods : sequence of str
        Methods to compare.
    out_dir : str, optional
        Writes ``comparison.csv`` and ``comparison_predictions.png``
        (paper Fig. 8: every method's prediction from the record's initial
        state and its error) there.
    seed : int
        Seed passed to the estimators.

    Returns
    -------
    DataFrame
        One column per method. Rows: the coefficients (``omega0`` [rad/s],
        ``b1`` [1/s], ``b2`` [-], ...), ``B44_full_kgm2_s`` and
        ``B44q_full_kgm2`` when the particulars are known, ``zeta_eq`` (at
        the first record's release amplitude), then per start ``S`` in
        ``record_start``, ``own_start``: ``MAE_deg_S`` and ``RMSE_deg_S``
        (pooled over the records whose replay stayed bounded; NaN when all
        diverged), ``diverged_S`` (how many replays diverged: counted, never
        averaged), ``phi0_deg_S`` and ``rate0_deg_s_S`` (the first record's
        start), and ``cpu_s``. ``attrs["starts"]`` says what each start is,
        ``attrs["initial_state_source"]`` how each method got its own.

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479, Table 6 and Fig. 8.
    """
    terms = tuple(terms)
    for meth in methods:
        _check_method_terms(meth, terms)
    train = [_load(p) for p in _as_list(data_paths)]
    valid = [_load(p) for p in _as_list(validate_paths)]
    on_training = not valid
    valid = valid or train
    part = _particulars(train)
    a_ref = abs(float(train[0]["phi"].iloc[0]))
    table: dict[str, dict[str, float]] = {}
    preds: dict[str, np.ndarray] = {}
    sources: dict[str, str] = {}
    for meth in methods:
        fit = make_method(meth, terms, seed).fit(train)
        sources[meth] = fit.meta.get("initial_state_source", "")
        col = {k: fit.params[k] for k in ("omega0",) + terms}
        if part is not None:
            dm = _dimensional_metrics(fit.params, part, a_ref)
            for k in ("B44_full_kgm2_s", "B44q_full_kgm2"):
                if f"dimensional/{k}" in dm:
                    col[k] = dm[f"dimensional/{k}"]
        col["zeta_eq"] = damping_ratio(fit.params, a_ref)
        replays = [_replays(fit, terms, r, _own_start(fit, i) if on_training else None)
                   for i, r in enumerate(valid)]
        for start in STARTS:
            done = [(r, rp[start]) for r, rp in zip(valid, replays) if start in rp]
            if not done:
                continue
            bounded = [(r, e) for r, e in done if not e.diverged]
            if bounded:
                meas = np.concatenate([r["phi"].to_numpy(float) for r, _ in bounded])
                pred = np.concatenate([e.predicted for _, e in bounded])
                col[f"MAE_deg_{start}"] = math.degrees(mae(meas, pred))
                col[f"RMSE_deg_{start}"] = math.degrees(rmse(meas, pred))
            else:
                col[f"MAE_deg_{start}"] = col[f"RMSE_deg_{start}"] = np.nan
            col[f"diverged_{start}"] = float(sum(e.diverged for _, e in done))
            col[f"phi0_deg_{start}"] = math.degrees(done[0][1].start[0])
            col[f"rate0_deg_s_{start}"] = math.degrees(done[0][1].start[1])
        col["cpu_s"] = fit.cpu_s
        table[meth] = col
        preds[meth] = replays[0]["record_start"].predicted
    df = pd.DataFrame(table)
    df.attrs["starts"] = dict(STARTS)
    df.attrs["initial_state_source"] = sources
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        df.to_csv(out / "comparison.csv", index_label="quantity")
        r0 = valid[0]
        plot_prediction(r0["t"], r0["phi"], preds, str(out / "comparison_predictions.png"),
                        title=f"{_stem(r0, 0)}: predictions of {', '.join(methods)} from the record's initial state")
    return df
