"""Chen et al. (2019) reproduced: Tables 5 and 6 beside the runs of ``experiment=roll_methods``.

Reads the runs of the preset (MLflow experiment ``roll_methods``): NLS, FLS
and NLS-SVM on the Table 5 style simulated decay (known damping) and on the
measured decays that stand in for the paper's Table 6 decay, and puts the
published values (:mod:`studies.papers`, ``chen2019.csv``) beside them, in
the paper's units and in the project's non-dimensional ones.

Everything comes from the runs' params and metrics. Every method's errors
were computed one way (:func:`studies.roll.comparison.replay_errors`) from
two starts, both reported: the record's own initial state (the same for
every method: like for like) and the method's own fitted one. A run whose
replay diverged is counted, never averaged (nothing here is averaged: each
cell shows its latest finished run and how many runs it has).

The causes of the disagreements are measured, not assumed: the share of the
quadratic term in the equivalent damping at the release angle (from the
runs' coefficients, and from the paper's own Table 6 values with its
Table 3 release angle), the difference between the FLS and NLS-SVM
coefficients, NLS's own initial rate against the record's, the change of
the measured period between the first and the last cycles, the number of
simulations NLS needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ...papers import DATA, PAPERS, published
from ...roll.comparison import STARTS
from ...roll.estimators import ESTIMATORS
from ..tables import markdown_table

__all__ = ["EXPERIMENTS", "COMMANDS", "sections", "substitutions", "conventions", "collect", "claims",
           "Cell", "TABLE5_INERTIA", "TIE"]

EXPERIMENTS = ("roll_methods",)
COMMANDS = ["studies run experiment=roll_methods    # from the project root, or with "
            "STUDIES_SHARED_DATA=<the shared data folder>"]
METHODS = ("nls", "fls", "nls_svm")
LABEL = {"nls": "NLS", "fls": "FLS", "nls_svm": "NLS-SVM"}
START_LABEL = {"record_start": "record's start", "own_start": "own start"}
#: [kg m^2] total roll inertia assumed to put Table 5's damping into the project's units
#: (the paper gives neither the inertia nor the natural frequency of its ULCV)
TABLE5_INERTIA = 1.0e11
#: two errors within this fraction of each other tie
TIE = 0.01
#: [rad/s] no ship of the paper's size rolls faster (T0 > 6.3 s): the bound of the paper's quadratic share
OMEGA0_BOUND = 1.0
#: [rad/s] a typical natural frequency of a ULCV (T0 = 25 s), as in the Table 5 set-up
OMEGA0_TYPICAL = 0.25
#: the paper's Table 6 condition
PAPER_SPEED_KN, PAPER_UKC_PCT = 12.0, 20.0
SIMULATED = "simulated"


@dataclass
class Cell:
    """The runs of one (case, method): the latest finished one and how many diverged.

    ``case`` is ``simulated`` or the record the run was identified on;
    ``diverged`` counts, per start, the finished runs whose replay diverged.
    """

    case: str
    method: str
    run: object
    runs: int = 0
    diverged: dict = field(default_factory=dict)

    @property
    def metrics(self) -> dict:
        return self.run.metrics

    @property
    def params(self) -> dict:
        return self.run.params

    def m(self, key: str) -> float:
        v = self.run.metrics.get(key)
        return float(v) if v is not None else float("nan")

    def diverged_latest(self, start: str) -> bool:
        return bool(self.run.metrics.get(f"fit/diverged_{start}", 0.0))

    def error(self, stem: str, kind: str, start: str) -> float:
        """``kind`` (``mae``/``rmse``) [deg] of record ``stem`` from ``start``; NaN when it diverged."""
        if self.diverged_latest(start):
            return float("nan")
        return self.m(f"{stem}/{kind}_deg_{start}")


# ------------------------------------------------------------------ reading
def _training_stems(metrics: dict) -> list[str]:
    return sorted(k[:-len("/is_training")] for k, v in metrics.items()
                  if k.endswith("/is_training") and v == 1.0)


def collect(runs: dict) -> dict:
    """``{(case, method): Cell}`` of the finished roll-decay runs of :data:`EXPERIMENTS`."""
    cells: dict = {}
    for experiment in EXPERIMENTS:
        for run in runs.get(experiment) or []:
            if run.status != "FINISHED" or run.params.get("model.study") != "roll_decay":
                continue
            method = run.params.get("method.name") or run.tags.get("method")
            if method not in METHODS:
                continue
            stems = _training_stems(run.metrics)
            case = SIMULATED if run.tags.get("data") == "simulated" else " + ".join(stems)
            cell = cells.get((case, method))
            if cell is None or run.start_time > cell.run.start_time:
                old = cell
                cell = Cell(case, method, run, old.runs if old else 0, dict(old.diverged) if old else {})
                cells[(case, method)] = cell
            cell.runs += 1
            for start in STARTS:
                if run.metrics.get(f"fit/diverged_{start}", 0.0):
                    cell.diverged[start] = cell.diverged.get(start, 0) + 1
    return cells


def _paper() -> pd.DataFrame:
    """The published tables, with ``printed``: each value as the paper prints it (its digits)."""
    table = published("roll_paper", "tables")
    table["printed"] = pd.read_csv(DATA / PAPERS["roll_paper"].tables["tables"], comment="#",
                                   dtype={"value": str})["value"]
    return table


def _pv(paper: pd.DataFrame, table: int, quantity: str, method: str | None = None,
        speed: float | None = None, ukc: float | None = None) -> float:
    """A published value in SI (value x factor); NaN when absent."""
    t = paper[(paper["table"] == str(table)) & (paper["quantity"] == quantity)]
    if method is not None:
        t = t[t["method"] == method]
    if speed is not None:
        t = t[t["speed_kn"] == speed]
    if ukc is not None:
        t = t[t["ukc_pct"] == ukc]
    if t.empty:
        return float("nan")
    return float(t["value"].iloc[0] * t["factor"].iloc[0])


def _particular(paper: pd.DataFrame, quantity: str, scale: str) -> float:
    """A Table 2 particular at ``scale`` (``full`` or ``model``), as printed."""
    t = paper[(paper["table"] == "2") & (paper["quantity"] == quantity) & paper["case"].str.contains(scale)]
    return float(t["value"].iloc[0]) if len(t) else float("nan")


def _printed(paper: pd.DataFrame, table: int, quantity: str, method: str) -> str:
    t = paper[(paper["table"] == str(table)) & (paper["quantity"] == quantity) & (paper["method"] == method)]
    return "-" if t.empty else str(t["printed"].iloc[0])


def _f(x, digits: int = 3) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.{digits}g}"


def _pct(x, digits: int = 2) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.{digits}f}"


def _rel(a: float, b: float) -> float:
    """|a - b| relative to the smaller magnitude."""
    return abs(a - b) / max(min(abs(a), abs(b)), 1e-300)


# -------------------------------------------------------------- the paper
def _paper_share(paper: pd.DataFrame, method: str, omega0: float) -> float:
    """Share of the quadratic term in the paper's equivalent damping of its Table 6
    decay at the Table 3 release angle, for a natural frequency ``omega0`` [rad/s]:
    (8 / 3 pi) omega0 phi_a B44q / (B44 + (8 / 3 pi) omega0 phi_a B44q)."""
    b1 = _pv(paper, 6, "b_phi", method)
    b2 = _pv(paper, 6, "b_phi_phi", method)
    phi_a = math.radians(_pv(paper, 3, "initial_roll", speed=PAPER_SPEED_KN, ukc=PAPER_UKC_PCT))
    q = 8.0 / (3.0 * math.pi) * omega0 * phi_a * b2
    return q / (b1 + q)


def _own_source(method: str) -> str:
    return ESTIMATORS[method].initial_state_source


# ------------------------------------------------------------------ claims
def _lowest(values: dict, who: str = "nls_svm", missing: dict | None = None) -> tuple[str, str]:
    """Verdict on "``who`` is lowest" and the measured values, in words.
    ``values``: method -> number (NaN for a diverged or missing one: ranked last);
    ``missing``: method -> the word shown instead of a NaN (default ``diverged``)."""
    missing = missing or {}
    shown = ", ".join(f"{LABEL[m]} {_f(v)}" if np.isfinite(v) else f"{LABEL[m]} {missing.get(m, 'diverged')}"
                      for m, v in values.items())
    finite = {m: v for m, v in values.items() if np.isfinite(v)}
    others = {m: v for m, v in finite.items() if m != who}
    if who not in finite:
        return "does not hold", shown + f" ({LABEL[who]} has none)"
    if not others:
        return "holds", shown
    best = min(others, key=others.get)
    if finite[who] < others[best] * (1.0 - TIE):
        return "holds", shown
    if finite[who] <= others[best] * (1.0 + TIE):
        return "tied", shown + f" ({LABEL[who]} within {100 * TIE:g} % of {LABEL[best]})"
    return "does not hold", shown + f" ({LABEL[best]} lowest)"


def claims(cells: dict) -> list[dict]:
    """The paper's claims, each against every record here and each start.

    Returns one dict per (claim, case, start) with ``claim``, ``source``
    (table and section), ``case``, ``start`` (``record_start``, ``own_start``
    or ``-``), ``paper`` and ``project`` (the numbers in words) and
    ``verdict`` (``holds``, ``tied``, ``does not hold``).
    """
    paper = _paper()
    out = []
    sim = {m: cells.get((SIMULATED, m)) for m in METHODS}
    if sim["nls_svm"] is not None:
        c = sim["nls_svm"]
        d1, d2 = abs(c.m("deviation_pct/b1")), abs(c.m("deviation_pct/b2"))
        lim1, lim2 = _pv(paper, 5, "b_phi_error", "nls_svm"), _pv(paper, 5, "b_phi_phi_error", "nls_svm")
        ok = d1 <= lim1 and d2 <= lim2
        out.append({"claim": "NLS-SVM identifies the known damping within 0.33 % (b_phi) and 1.00 % (b_phi_phi)",
                    "source": "Table 5, section 5.1", "case": SIMULATED, "start": "-",
                    "paper": f"{lim1:g} %, {lim2:.2f} %", "project": f"{_pct(d1, 3)} %, {_pct(d2, 3)} %",
                    "verdict": "holds" if ok else "does not hold"})
    cases = sorted({case for case, _ in cells if case != SIMULATED})
    for case in cases:
        here = {m: cells.get((case, m)) for m in METHODS}
        if any(c is None for c in here.values()) or " + " in case:
            continue
        for kind, col in (("mae", "MAE"), ("rmse", "RMSE")):
            for start in STARTS:
                vals = {m: here[m].error(case, kind, start) for m in METHODS}
                verdict, shown = _lowest(vals, missing={m: "diverged" if here[m].diverged_latest(start)
                                                        else "no value" for m in METHODS})
                pv = {m: _pv(paper, 6, col, m) / 1e-2 for m in METHODS}
                out.append({"claim": f"NLS-SVM has the lowest {col}", "source": "Table 6, section 5.2",
                            "case": case, "start": start,
                            "paper": ", ".join(f"{LABEL[m]} {v:.2f}e-2" for m, v in pv.items()) + " deg",
                            "project": shown + " deg", "verdict": verdict})
        q = {m: here[m].m("coef/b2") for m in METHODS}
        ratio = {m: q["nls"] / q[m] for m in ("fls", "nls_svm")}
        pq = {m: _pv(paper, 6, "b_phi_phi", m) for m in METHODS}
        pratio = {m: pq["nls"] / pq[m] for m in ("fls", "nls_svm")}
        out.append({"claim": "NLS's quadratic damping is about 100 times smaller than FLS's and NLS-SVM's "
                             "(criterion: at least 10 times smaller than both)",
                    "source": "Table 6, section 5.2", "case": case, "start": "-",
                    "paper": f"NLS / FLS {pratio['fls']:.3g}, NLS / NLS-SVM {pratio['nls_svm']:.3g}",
                    "project": f"NLS / FLS {ratio['fls']:.3g}, NLS / NLS-SVM {ratio['nls_svm']:.3g}",
                    "verdict": "holds" if max(ratio.values()) <= 0.1 else "does not hold"})
        lin = {m: here[m].m("coef/b1") for m in METHODS}
        spread = max(lin.values()) / min(lin.values())
        pl = {m: _pv(paper, 6, "b_phi", m) for m in METHODS}
        out.append({"claim": "all three give the linear damping within the same magnitude "
                             "(criterion: largest / smallest below 2)",
                    "source": "Table 6, section 5.2", "case": case, "start": "-",
                    "paper": f"largest / smallest {max(pl.values()) / min(pl.values()):.3g}",
                    "project": f"largest / smallest {spread:.3g}",
                    "verdict": "holds" if spread < 2.0 else "does not hold"})
        cpu = {m: here[m].m("cpu_s") for m in METHODS}
        verdict, shown = _lowest(cpu, missing={m: "no value" for m in METHODS})
        out.append({"claim": "NLS-SVM takes the least CPU time", "source": "Table 6, section 5.2",
                    "case": case, "start": "-",
                    "paper": ", ".join(f"{LABEL[m]} {_pv(paper, 6, 'CPU', m):g}" for m in METHODS) + " s",
                    "project": shown + " s", "verdict": verdict})
    return out


# ---------------------------------------------------------------- sections
def _table5(cells: dict, paper: pd.DataFrame) -> str:
    sim = {m: cells.get((SIMULATED, m)) for m in METHODS}
    present = [m for m in METHODS if sim[m] is not None]
    if not present:
        return "No finished run on the simulated decay (`data.path=null`) in the store.\n"
    p0 = sim[present[0]].params
    known = {k: float(p0.get(f"model.synthetic.{k}", "nan")) for k in ("omega0", "b1", "b2")}
    I = TABLE5_INERTIA
    is_table5 = (math.isclose(known["b1"] * I, _pv(paper, 5, "b_phi", "known"), rel_tol=1e-6)
                 and math.isclose(known["b2"] * I, _pv(paper, 5, "b_phi_phi", "known"), rel_tol=1e-6))
    rows = {}
    pk1, pk2 = _pv(paper, 5, "b_phi", "known"), _pv(paper, 5, "b_phi_phi", "known")
    rows["b_phi = B44 [1e8 kg m^2/s]"] = {"known (paper)": _printed(paper, 5, "b_phi", "known"),
                                         "paper NLS-SVM": _printed(paper, 5, "b_phi", "nls_svm")}
    rows["b_phi_phi = B44q [1e7 kg m^2]"] = {"known (paper)": _printed(paper, 5, "b_phi_phi", "known"),
                                             "paper NLS-SVM": _printed(paper, 5, "b_phi_phi", "nls_svm")}
    rows["error of b_phi [%]"] = {"known (paper)": "", "paper NLS-SVM": _printed(paper, 5, "b_phi_error", "nls_svm")}
    rows["error of b_phi_phi [%]"] = {"known (paper)": "",
                                      "paper NLS-SVM": _printed(paper, 5, "b_phi_phi_error", "nls_svm")}
    rows["b1 = B44 / I [1/s]"] = {"known (paper)": _f(pk1 / I, 4), "paper NLS-SVM": _f(_pv(paper, 5, "b_phi", "nls_svm") / I, 4)}
    rows["b2 = B44q / I [-]"] = {"known (paper)": _f(pk2 / I, 4), "paper NLS-SVM": _f(_pv(paper, 5, "b_phi_phi", "nls_svm") / I, 4)}
    rows["omega0 [rad/s]"] = {"known (paper)": "not given", "paper NLS-SVM": "not identified"}
    for m in METHODS:
        c = sim[m]
        col = f"project {LABEL[m]}"
        if c is None:
            for r in rows:
                rows[r][col] = "-"
            continue
        b1, b2, w0 = c.m("coef/b1"), c.m("coef/b2"), c.m("coef/omega0")
        rows["b_phi = B44 [1e8 kg m^2/s]"][col] = _f(b1 * I / 1e8, 6)
        rows["b_phi_phi = B44q [1e7 kg m^2]"][col] = _f(b2 * I / 1e7, 6)
        rows["error of b_phi [%]"][col] = _pct(c.m("deviation_pct/b1"), 4)
        rows["error of b_phi_phi [%]"][col] = _pct(c.m("deviation_pct/b2"), 4)
        rows["b1 = B44 / I [1/s]"][col] = _f(b1, 6)
        rows["b2 = B44q / I [-]"][col] = _f(b2, 6)
        rows["omega0 [rad/s]"][col] = _f(w0, 6)
    table = pd.DataFrame(rows).T
    table.insert(2, "known (project)", [_f(known["b1"] * I / 1e8, 6), _f(known["b2"] * I / 1e7, 6), "", "",
                                        _f(known["b1"], 4), _f(known["b2"], 4), _f(known["omega0"], 4)])
    share = sim[present[0]].m("equivalent/quadratic_share_at_release")
    p = sim[present[0]].params
    head = (f"The project's decay: phi'' + b1 phi' + b2 |phi'| phi' + omega0^2 phi = 0 with b1 = "
            f"{_f(known['b1'], 4)} 1/s, b2 = {_f(known['b2'], 4)}, omega0 = {_f(known['omega0'], 4)} rad/s, "
            f"released from rest at {p.get('model.synthetic.phi0_deg', '?')} deg, "
            f"{p.get('model.synthetic.duration', '?')} s at {p.get('model.synthetic.dt', '?')} s, noise "
            f"{p.get('model.synthetic.noise', '?')} (RK4, as the paper's). ")
    if is_table5:
        head += (f"These are Table 5's B44 and B44q divided by the assumed total inertia I = {I:.1e} kg m^2; "
                 "the paper's units follow by multiplying the project's b1 and b2 by I (the relative errors "
                 "do not depend on I). ")
    else:
        head += (f"These are not Table 5's damping divided by I = {I:.1e} kg m^2: the paper's units below use "
                 "that I all the same; compare the errors [%], which do not depend on it. ")
    head += quadratic_share_sentence(share) + "\n\n"
    return head + markdown_table(table, "quantity")


#: below this share of the equivalent linear damping at release the quadratic term barely shapes the decay
MINOR_QUADRATIC_SHARE = 0.1
#: a single omega0 follows a decay whose phase it misses by less than this at the record's ends [deg]
PHASE_FOLLOWED_DEG = 30.0


def quadratic_share_sentence(share: float) -> str:
    """What the quadratic damping's share of the equivalent damping at release says of Table 5's
    ``b_phi_phi`` errors: judged against :data:`MINOR_QUADRATIC_SHARE`, "not measured" when missing."""
    if not np.isfinite(share):
        return "The quadratic term's share of the damping at release was not measured."
    text = (f"At the release angle the quadratic term is {_pct(100 * share)} % of the equivalent linear damping "
            "(from NLS-SVM's coefficients, (8 / 3 pi) omega0 phi_a b2 / b_eq)")
    if share < MINOR_QUADRATIC_SHARE:
        return (text + f", below {100 * MINOR_QUADRATIC_SHARE:g} %: the decay hardly depends on Table 5's "
                "b_phi_phi, so its errors here and in the paper are numerical accuracies on noise-free data.")
    return (text + f", at least {100 * MINOR_QUADRATIC_SHARE:g} %: the decay depends on Table 5's b_phi_phi, "
            "and its errors measure how well each method identifies it.")


def _substitute_rows(case: str, here: dict, paper: pd.DataFrame) -> pd.DataFrame:
    cols = [f"paper {LABEL[m]}" for m in METHODS] + [f"project {LABEL[m]}" for m in METHODS]
    rows: dict[str, list] = {}
    phi_paper = _pv(paper, 3, "initial_roll", speed=PAPER_SPEED_KN, ukc=PAPER_UKC_PCT)

    def add(label, paper_vals, project_vals):
        rows[label] = list(paper_vals) + list(project_vals)

    def proj(fn):
        return [fn(here[m]) if here[m] is not None else "-" for m in METHODS]

    add("b_phi = B44 [1e9 kg m^2/s], full scale", [_printed(paper, 6, "b_phi", m) for m in METHODS],
        proj(lambda c: _f(c.m("dimensional/B44_full_kgm2_s") / 1e9)))
    add("b_phi_phi = B44q [1e7 kg m^2], full scale", [_printed(paper, 6, "b_phi_phi", m) for m in METHODS],
        proj(lambda c: _f(c.m("dimensional/B44q_full_kgm2") / 1e7)))
    add("B44q / B44 = b2 / b1 [s], full scale",
        [_f(_pv(paper, 6, "b_phi_phi", m) / _pv(paper, 6, "b_phi", m)) for m in METHODS],
        proj(lambda c: _f(c.m("dimensional/B44q_full_kgm2") / c.m("dimensional/B44_full_kgm2_s"))))
    add("b1 = B44 / I [1/s], model scale", ["-"] * 3, proj(lambda c: _f(c.m("coef/b1"), 4)))
    add("b2 = B44q / I [-]", ["-"] * 3, proj(lambda c: _f(c.m("coef/b2"), 4)))
    add("omega0 [rad/s], model scale", ["known, not given"] * 3, proj(lambda c: _f(c.m("coef/omega0"), 5)))
    add("I = C44 / omega0^2 [kg m^2], full scale", ["not given"] * 3,
        proj(lambda c: _f(c.m("dimensional/I_total_full_kgm2"))))
    add("quadratic share of the damping at the release [%]",
        [f"{_pct(100 * _paper_share(paper, m, OMEGA0_TYPICAL), 3)} ({_pct(100 * _paper_share(paper, m, OMEGA0_BOUND), 3)})"
         for m in METHODS],
        proj(lambda c: _pct(100 * c.m("equivalent/quadratic_share_at_release"), 1)))
    for kind, col in (("mae", "MAE"), ("rmse", "RMSE")):
        for start in STARTS:
            pvals = ([_printed(paper, 6, col, m) for m in METHODS] if start == "record_start" else ["-"] * 3)
            add(f"{col} [1e-2 deg], {START_LABEL[start]}", pvals,
                proj(lambda c, k=kind, s=start: ("diverged" if c.diverged_latest(s)
                                                else _f(c.error(case, k, s) / 1e-2))))
    add("MAE / release angle [%], record's start",
        [_pct(_pv(paper, 6, "MAE", m) / phi_paper * 100) for m in METHODS],
        proj(lambda c: _pct(c.error(case, "mae", "record_start") / c.m(f"{case}/release_amplitude_deg") * 100)))
    add("start: angle [deg], rate [deg/s]", [f"{phi_paper:g}, 0 (Table 3)"] * 3,
        proj(lambda c: f"{_f(c.m(f'{case}/phi0_deg_own_start'), 4)}, {_f(c.m(f'{case}/rate0_deg_s_own_start'), 3)} "
                       f"(record's {_f(c.m(f'{case}/phi0_deg_record_start'), 4)}, "
                       f"{_f(c.m(f'{case}/rate0_deg_s_record_start'), 2)})"))
    add("CPU time [s]", [_printed(paper, 6, "CPU", m) for m in METHODS], proj(lambda c: _f(c.m("cpu_s"), 2)))
    add("runs (diverged: record's / own start)", ["-"] * 3,
        proj(lambda c: f"{c.runs} ({c.diverged.get('record_start', 0)} / {c.diverged.get('own_start', 0)})"))
    return pd.DataFrame(rows, index=cols).T


def _table6(case: str, here: dict, paper: pd.DataFrame) -> str:
    c = next(c for c in here.values() if c is not None)
    speed = c.m(f"{case}/speed_kn_full_scale")
    scale = c.m(f"{case}/scale_factor")
    what = (f"`{case}` ({c.run.tags.get('vessel', 'unknown vessel')}"
            + (f", 1:{scale:g}" if np.isfinite(scale) else "")
            + (f", {speed:g} kn" if np.isfinite(speed) else ", speed not stated")
            + f", released from {_f(c.m(f'{case}/release_amplitude_deg'), 3)} deg, "
              f"{_f(c.m(f'{case}/duration_s'), 4)} s) stands in for the paper's ULCV decay at "
              f"{PAPER_SPEED_KN:g} kn and {PAPER_UKC_PCT:g} % UKC (see the substitutions above).")
    text = (what + " Paper: the ULCV at full scale (Table 6 as printed); project: the KVLCC2 at full scale "
            "from its identified b1, b2 and omega0 (Froude-scaled from 1:scale, times I = rho g V GM / "
            "omega0^2 from the particulars beside the record). Errors over the whole record from the "
            "release: the paper's most likely from the record's start (section above); "
            f"own start: NLS {_own_source('nls')}, FLS and NLS-SVM {_own_source('nls_svm')}. "
            "The paper's quadratic share is computed from its own Table 6 and the Table 3 release angle at "
            f"omega0 = {OMEGA0_TYPICAL:g} rad/s (in brackets at {OMEGA0_BOUND:g} rad/s, an upper bound for a "
            "ship of its size); a diverged replay shows `diverged` and is counted in the last row.\n\n")
    return text + markdown_table(_substitute_rows(case, here, paper), "quantity")


def _claims_section(found: list) -> str:
    if not found:
        return "No finished runs to judge the paper's claims on.\n"
    frame = pd.DataFrame(found)
    frame["start"] = frame["start"].map(lambda s: START_LABEL.get(s, s))
    frame = frame[["claim", "source", "case", "start", "paper", "project", "verdict"]]
    counts = frame["verdict"].value_counts()
    summary = ", ".join(f"{counts.get(v, 0)} {v}" for v in ("holds", "tied", "does not hold"))
    return (f"Each claim judged on every decay and, for the errors, from both starts (like for like: every "
            f"method's errors computed the same way). {summary}. Two errors within {100 * TIE:g} % tie.\n\n"
            + markdown_table(frame.set_index("claim"), "claim"))


def _period_sentence(c: Cell, case: str) -> str:
    p1, p2 = c.m(f"{case}/period_first_s"), c.m(f"{case}/period_last_s")
    a1, a2 = c.m(f"{case}/amplitude_first_deg"), c.m(f"{case}/amplitude_last_deg")
    if not (np.isfinite(p1) and np.isfinite(p2)):
        return ""
    n = c.m(f"{case}/duration_s") / (0.5 * (p1 + p2))
    # one omega0 between the two periods misses the phase by about half the change times the
    # number of periods from the middle to either end
    drift = 360.0 * 0.5 * abs(p2 - p1) / (0.5 * (p1 + p2)) * 0.5 * n
    text = (f"the measured period changes from {p1:.4g} s over the first cycles ({a1:.3g} deg) to {p2:.4g} s over "
            f"the last ({a2:.3g} deg), {100 * (p2 - p1) / p1:+.2f} %: one omega0 between them misses the phase "
            f"by about {drift:.0f} deg at the ends of the record's {n:.0f} periods, ")
    if drift >= PHASE_FOLLOWED_DEG:
        text += f"at least {PHASE_FOLLOWED_DEG:g} deg, so a model with one omega0 cannot follow it"
    else:
        text += f"less than {PHASE_FOLLOWED_DEG:g} deg, so a model with one omega0 follows it"
    return text + f", while the noise is {c.m(f'{case}/noise_deg'):.2g} deg"


def _phase_deg(c: Cell, case: str) -> float:
    """Phase [deg] of the method's own start against the record's: atan of rate / (omega0 angle)."""
    w0 = c.m("coef/omega0")
    own = math.atan2(-math.radians(c.m(f"{case}/rate0_deg_s_own_start")) / w0,
                     math.radians(c.m(f"{case}/phi0_deg_own_start")))
    rec = math.atan2(-math.radians(c.m(f"{case}/rate0_deg_s_record_start")) / w0,
                     math.radians(c.m(f"{case}/phi0_deg_record_start")))
    return abs(math.degrees((own - rec + math.pi) % (2 * math.pi) - math.pi))


def disagreements(cells: dict, found: list) -> list[str]:
    """A sentence per claim that does not hold (or ties), with its measured cause."""
    paper = _paper()
    out = []
    for row in found:
        if row["verdict"] == "holds":
            continue
        case, start = row["case"], row["start"]
        here = {m: cells.get((case, m)) for m in METHODS}
        where = f"`{case}`" + (f", {START_LABEL[start]}" if start in START_LABEL else "")
        claim = row["claim"].split(" (criterion")[0]
        if claim.startswith("NLS-SVM has the lowest"):
            kind = "mae" if "MAE" in claim else "rmse"
            fls, svm, nls = here["fls"], here["nls_svm"], here["nls"]
            parts = []
            e = {m: here[m].error(case, kind, start) for m in METHODS}
            pe = {m: _pv(paper, 6, kind.upper(), m) for m in METHODS}
            if np.isfinite(e["fls"]) and np.isfinite(e["nls_svm"]) and _rel(e["fls"], e["nls_svm"]) <= 3 * TIE \
                    and start == "record_start":
                parts.append(
                    "FLS and NLS-SVM are one estimator (least squares on the same filtered equation rows) with "
                    f"two smoothers, and both follow this record: their b1 differ by "
                    f"{100 * _rel(fls.m('coef/b1'), svm.m('coef/b1')):.2f} %, their b2 by "
                    f"{100 * _rel(fls.m('coef/b2'), svm.m('coef/b2')):.2f} %, so their replays from the same start "
                    f"differ by {100 * _rel(e['fls'], e['nls_svm']):.2f} % (in the paper FLS and NLS-SVM differ "
                    f"by {100 * _rel(_pv(paper, 6, 'b_phi', 'fls'), _pv(paper, 6, 'b_phi', 'nls_svm')):.1f} % in "
                    f"b_phi and NLS-SVM's {kind.upper()} is {100 * (1 - pe['nls_svm'] / pe['fls']):.1f} % below "
                    "FLS's)")
            if start == "own_start" and np.isfinite(e["nls"]) and e["nls"] < min(e["fls"], e["nls_svm"]):
                parts.append(
                    "NLS minimises the squared error of exactly this replay (from an initial state it fits with "
                    f"the coefficients), so from its own start it is lowest by construction; its start has a rate "
                    f"of {nls.m(f'{case}/rate0_deg_s_own_start'):.3g} deg/s where the record's is "
                    f"{nls.m(f'{case}/rate0_deg_s_record_start'):.2g} deg/s (released from rest), a phase shift of "
                    f"{_phase_deg(nls, case):.1f} deg that lowers its RMSE from "
                    f"{_f(nls.error(case, 'rmse', 'record_start'))} to {_f(nls.error(case, 'rmse', 'own_start'))} "
                    f"deg by taking up part of a drift ({_period_sentence(nls, case)}); FLS's and NLS-SVM's own "
                    f"starts are their curve fits at the first sample (rates "
                    f"{fls.m(f'{case}/rate0_deg_s_own_start'):.3g} and {svm.m(f'{case}/rate0_deg_s_own_start'):.3g} "
                    "deg/s), edge values their regressions leave out")
            if start == "record_start" and np.isfinite(e["nls"]) and np.isfinite(e["nls_svm"]) \
                    and e["nls"] < e["nls_svm"] * (1 - TIE):
                other = "rmse" if kind == "mae" else "mae"
                parts.append(
                    f"NLS's {kind.upper()} is lower here while its {other.upper()} is "
                    f"{'higher' if nls.error(case, other, start) > svm.error(case, other, start) else 'lower'} "
                    f"({_f(nls.error(case, other, start))} against NLS-SVM's {_f(svm.error(case, other, start))} "
                    f"deg), with other coefficients (b1 {nls.m('coef/b1'):.4g}, b2 {nls.m('coef/b2'):.4g} against "
                    f"{svm.m('coef/b1'):.4g}, {svm.m('coef/b2'):.4g}): the errors are mostly a phase drift that "
                    f"the two measures weigh differently ({_period_sentence(nls, case)})")
            if start == "record_start" and np.isfinite(e["nls"]) and np.isfinite(e["nls_svm"]) \
                    and e["nls"] > e["nls_svm"] * (1 + TIE) and not any("NLS is lower" in p for p in parts):
                parts.append(
                    "NLS is higher from the record's start than from its own "
                    f"({_f(nls.error(case, kind, 'own_start'))} deg): its coefficients were fitted together "
                    f"with an initial rate of {nls.m(f'{case}/rate0_deg_s_own_start'):.3g} deg/s that the record "
                    "does not have")
            if not parts:
                parts.append("no measured property of these runs explains it")
            out.append(f"- **{claim}** ({where}): {row['verdict']}; " + "; ".join(parts) + ".")
        elif claim.startswith("NLS's quadratic damping"):
            shares = {m: here[m].m("equivalent/quadratic_share_at_release") for m in METHODS}
            out.append(
                f"- **{claim}** ({where}): {row['verdict']}; {row['project']} here against the paper's "
                f"{row['paper']}. On this decay the quadratic term carries "
                f"{100 * min(shares.values()):.0f}-{100 * max(shares.values()):.0f} % of the equivalent damping at "
                f"the release ({_f(here['nls'].m(f'{case}/release_amplitude_deg'), 3)} deg), "
                + ("so it shapes the decay" if min(shares.values()) >= MINOR_QUADRATIC_SHARE
                   else f"below {100 * MINOR_QUADRATIC_SHARE:g} % on some starts, so it barely shapes the decay")
                + f", and NLS finds it within {100 * _rel(here['nls'].m('coef/b2'), here['nls_svm'].m('coef/b2')):.0f} % "
                "of NLS-SVM's. In the paper's decay, released from "
                f"{_pv(paper, 3, 'initial_roll', speed=PAPER_SPEED_KN, ukc=PAPER_UKC_PCT):g} deg (Table 3), its "
                f"own NLS-SVM values make it {100 * _paper_share(paper, 'nls_svm', OMEGA0_TYPICAL):.3f} % of the "
                f"damping at omega0 = {OMEGA0_TYPICAL:g} rad/s and at most "
                f"{100 * _paper_share(paper, 'nls_svm', OMEGA0_BOUND):.2f} % at {OMEGA0_BOUND:g} rad/s: "
                + ("there b_phi_phi barely changes the decay (below "
                   f"{100 * MINOR_QUADRATIC_SHARE:g} %), so the decay cannot tell a value 100 times smaller from "
                   "NLS-SVM's, and Table 6's difference says nothing about NLS's ability to find a quadratic "
                   "damping that matters."
                   if _paper_share(paper, "nls_svm", OMEGA0_BOUND) < MINOR_QUADRATIC_SHARE else
                   f"there b_phi_phi shapes the decay too (at least {100 * MINOR_QUADRATIC_SHARE:g} %), and Table "
                   "6's difference is a difference in finding it."))
        elif claim.startswith("NLS-SVM takes the least CPU"):
            nls = here["nls"]
            fls_cv, svm_cv = ESTIMATORS["fls"](), ESTIMATORS["nls_svm"]()
            out.append(
                f"- **{claim}** ({where}): {row['verdict']}; {row['project']}. NLS's least squares evaluated "
                f"its residual {_f(nls.m('method/nfev'), 3)} times (plus finite-difference Jacobians, one "
                "compiled RK4 replay per unknown each), started from the decay-curve fit (log decrement); FLS "
                f"chooses its smoothing by {fls_cv.n_folds}-fold cross-validation over {len(fls_cv.lam_grid)} "
                f"candidates, NLS-SVM its kernel width and penalty by leave-one-out over "
                f"{len(svm_cv.sigma_grid)} x {len(svm_cv.gamma_grid)} candidates on {svm_cv.cv_windows} windows. "
                "The paper does not give its NLS's start, integrator or software (97 s), so its times are not "
                "comparable with these.")
        elif claim.startswith("all three give the linear damping"):
            out.append(f"- **{claim}** ({where}): {row['verdict']}; {row['project']} (paper {row['paper']}).")
        elif claim.startswith("NLS-SVM identifies the known damping"):
            out.append(f"- **{claim}**: {row['verdict']}; {row['project']} (paper {row['paper']}).")
    if not out:
        out.append("- Every claim holds on these runs.")
    # the level of the errors, measured against the paper's, once per record
    for case in sorted({r["case"] for r in found if r["case"] != SIMULATED}):
        svm = cells.get((case, "nls_svm"))
        if svm is None:
            continue
        mae = svm.error(case, "mae", "record_start")
        rel = mae / svm.m(f"{case}/release_amplitude_deg")
        prel = _pv(paper, 6, "MAE", "nls_svm") / _pv(paper, 3, "initial_roll", speed=PAPER_SPEED_KN,
                                                      ukc=PAPER_UKC_PCT)
        nls = cells.get((case, "nls"))
        best = nls.error(case, "rmse", "own_start") if nls is not None else float("nan")
        floor = (f" Even the best replay this model gives (NLS from its own start, which minimises that RMSE) "
                 f"has an RMSE of {_f(best)} deg, {_f(best / svm.m(f'{case}/noise_deg'))} times the noise: the "
                 "errors are the model's (b1 + b2 with one omega0), not the noise's nor one method's."
                 if np.isfinite(best) else "")
        out.append(f"- **Level of the errors** (`{case}`): NLS-SVM's MAE is {_f(mae)} deg, "
                   f"{_f(mae / _pv(paper, 6, 'MAE', 'nls_svm'))} times the paper's, "
                   f"{100 * rel:.2f} % of the release angle against the paper's {100 * prel:.2f} %; "
                   f"{_period_sentence(svm, case)}.{floor}")
    return out


def _which_start() -> str:
    return (
        "The paper does not say from which state its predictions start. Its Table 6 errors most likely "
        "replay every method from the record's initial state (the measured release angle, at rest): its "
        "Table 4, step 5, substitutes only the identified damping into eq. 3 and integrates it by RK4; its "
        "Table 3 lists the initial roll angle of every test, which is what such a replay needs; section 4.3 "
        "describes the model held at that angle and released (at rest); and section 5.2 has NLS and FLS "
        "identify the 'unknown parameters', the damping, with no initial state named among them (its Figs 6 "
        "and 8 are missing from the text copy). The `record's start` rows below are therefore the like-for-like "
        "comparison with Table 6; the `own start` rows show what NLS was fitted to (the project's NLS "
        "estimates the initial state with the coefficients, so from the record's start it is judged on a "
        "decay it was not fitted to).\n")


def _tables78(paper: pd.DataFrame) -> str:
    rows = []
    for table, key, section in ((7, "ukc_pct", "5.3.1"), (8, "speed_kn", "5.3.2")):
        t = paper[paper["table"] == str(table)]
        for value in sorted(t[key].unique()):
            sub = t[t[key] == value].set_index("quantity")
            rows.append({"table": f"{table} (section {section})",
                         "condition": f"{value:g} % UKC, 6 kn" if key == "ukc_pct" else f"{value:g} kn, 20 % UKC",
                         "b_phi [1e9 kg m^2/s]": sub.loc["b_phi", "printed"],
                         "b_phi_phi [1e7 kg m^2]": sub.loc["b_phi_phi", "printed"],
                         "MAE [1e-2 deg]": sub.loc["MAE", "printed"],
                         "RMSE [1e-2 deg]": sub.loc["RMSE", "printed"],
                         "CPU [s]": sub.loc["CPU", "printed"]})
    return ("NLS-SVM over under keel clearances and speeds. The project's decays are of one ship at one speed "
            "and an unstated depth, so these are not reproduced; they are used above to say what the "
            "substitution of Table 6's decay changes.\n\n"
            + markdown_table(pd.DataFrame(rows).set_index("table"), "table"))


# ---------------------------------------------------------------- protocol
def substitutions(runs: dict) -> list:
    paper = _paper()
    cells = collect(runs)
    cases = sorted({case for case, _ in cells if case != SIMULATED})
    phi_paper = _pv(paper, 3, "initial_roll", speed=PAPER_SPEED_KN, ukc=PAPER_UKC_PCT)
    out = []
    if cases:
        described = []
        for case in cases:
            c = next(cells[(case, m)] for m in METHODS if (case, m) in cells)
            speed = c.m(f"{case}/speed_kn_full_scale")
            scale = c.m(f"{case}/scale_factor")
            described.append(
                f"`{case}` ({c.run.tags.get('vessel', 'unknown vessel')}"
                + (f", model 1:{scale:g}" if np.isfinite(scale) else "")
                + (f", {speed:g} kn" if np.isfinite(speed) else ", speed not stated")
                + f", released from {_f(c.m(f'{case}/release_amplitude_deg'), 3)} deg, "
                  f"{_f(c.m(f'{case}/duration_s'), 4)} s)")
        speeds = sorted({cells[(c, m)].m(f"{c}/speed_kn_full_scale") for c, m in cells if c != SIMULATED})
        lpp_full, lpp_model = _particular(paper, "L_PP", "full"), _particular(paper, "L_PP", "model")
        out.append(
            f"Table 6's decay: the paper's 1/{lpp_full / lpp_model:.0f} ULCV (Lpp {lpp_full:g} m, "
            f"{_particular(paper, 'm', 'full'):g} t, Table 2) at {PAPER_SPEED_KN:g} kn and {PAPER_UKC_PCT:g} % UKC (shallow water), released from "
            f"{phi_paper:g} deg (Table 3), is not available. The free decay model tests "
            + ", ".join(described)
            + " stand in for it, each identified on its own and its errors computed on itself, as Table 6's are. "
              "Their water depth is not stated by the data (the parameter file beside them has no depth or "
              "under-keel-clearance column), so whether they are deep or shallow cannot be told; nothing "
              "marks them as shallow-water tests.")
        t8 = {kn: (_pv(paper, 8, "b_phi", speed=kn), _pv(paper, 8, "b_phi_phi", speed=kn)) for kn in (0.0, 12.0)}
        t7 = {u: _pv(paper, 7, "b_phi", ukc=u) for u in (20.0, 190.0)}
        shares = [v for v in (cells[(c, m)].m("equivalent/quadratic_share_at_release")
                              for c, m in cells if c != SIMULATED) if np.isfinite(v)] or [float("nan")]
        out.append(
            "What that changes: (a) speed, "
            + ("the stand-in decays are at " + ", ".join(f"{s:g}" for s in speeds if np.isfinite(s)) + " kn: "
               if any(np.isfinite(s) for s in speeds) else "the stand-in decays' speed is not stated: ")
            + f"the paper's own Table 8 (20 % UKC) gives b_phi {t8[0.0][0] / 1e9:.2f}e9 at 0 kn and "
              f"{t8[12.0][0] / 1e9:.2f}e9 at 12 kn ({100 * (t8[12.0][0] / t8[0.0][0] - 1):+.0f} %) and b_phi_phi "
              f"{100 * (t8[12.0][1] / t8[0.0][1] - 1):+.0f} %: a decay at rest lacks the damping forward speed adds; "
              f"(b) depth: Table 7 (6 kn) gives b_phi {t7[190.0] / 1e9:.2f}e9 at 190 % UKC and {t7[20.0] / 1e9:.2f}e9 "
              f"at 20 % UKC ({t7[20.0] / t7[190.0]:.1f} times), and the stand-ins' depth is unknown; (c) ship: "
              "another hull, mass and scale, so the dimensional damping is not comparable and only the orderings "
              "and ratios are; (d) amplitude: released from about 10 deg instead of "
              f"{phi_paper:g} deg, the quadratic term carries {100 * min(shares):.0f}-{100 * max(shares):.0f} % of "
              f"the damping at the release here and at most {100 * _paper_share(paper, 'nls_svm', OMEGA0_BOUND):.2f} "
              "% in the paper's decay (Table 6 section below)"
              + (", so these decays test whether a method finds b2, which the paper's 12 kn decay cannot."
                 if min(shares) >= MINOR_QUADRATIC_SHARE > _paper_share(paper, "nls_svm", OMEGA0_BOUND) else "."))
    sim = [c for (case, _), c in cells.items() if case == SIMULATED]
    if sim:
        p = sim[0].params
        out.append(
            "Table 5's decay: the paper gives neither its ULCV's roll inertia nor its natural frequency (they are "
            "in Tello Ruiz 2018), nor the release angle, length or step of its simulated decay. The project "
            f"simulates b1 = {p.get('model.synthetic.b1')} 1/s and b2 = {p.get('model.synthetic.b2')} at omega0 = "
            f"{p.get('model.synthetic.omega0')} rad/s, from {p.get('model.synthetic.phi0_deg')} deg for "
            f"{p.get('model.synthetic.duration')} s at {p.get('model.synthetic.dt')} s with noise "
            f"{p.get('model.synthetic.noise')}: Table 5's damping over an assumed I = {TABLE5_INERTIA:.1e} kg m^2 "
            "(m = 165 046 t, kxx = 0.4 B, 20 % added inertia) at T0 = 25 s.")
    out.append(
        "Methods: NLS = scipy's least_squares (trust region) on the compiled RK4 replay, from the decay-curve "
        "fit, with each record's initial state estimated too; FLS = a smoothing spline (smoothing by 5-fold "
        "cross-validation), its analytic derivatives, least squares on the ODE; NLS-SVM = windowed LS-SVM with "
        "an RBF kernel (width and penalty by leave-one-out cross-validation), its analytic derivatives, least "
        "squares on the ODE. The paper gives neither its kernel width and penalty factor nor its NLS solver.")
    out.append(
        "CPU time: the project's is the process time of the identification alone (one BLAS thread, the "
        "integrator compiled beforehand); the paper does not say what its times include or which software "
        "ran them.")
    return out


def conventions(runs: dict) -> list:
    return [
        "Model: the paper's eq. 3 is dimensional, (I_xx + A44) phi'' + b_phi phi' + b_phi_phi |phi'| phi' + "
        "C44 phi = 0 (the memory-effect convolution left out in its identification as in the project's), "
        "with the inertia and restoring known and only the two damping coefficients identified. The "
        "project divides by the inertia I = I_xx + A44 and identifies omega0 as well: phi'' + b1 phi' + b2 "
        "|phi'| phi' + omega0^2 phi = 0, b1 = B44 / I [1/s], b2 = B44q / I [-], omega0^2 = C44 / I. Back to "
        "the paper's units: B44 = b1 I and B44q = b2 I with I = C44 / omega0^2 = rho g V GM / omega0^2 "
        "(measured decays: V and GM from the particulars beside the record, at full scale after Froude "
        "scaling, b1 and omega0 times 1 / sqrt(scale), b2 unchanged; Table 5: the assumed I). "
        "B44q / B44 = b2 / b1 [s] needs no inertia.",
        "Angles and rates in radians in the model (so b2 is per rad); errors in degrees. The paper's "
        "quadratic damping (b_phi_phi here, printed b_{phi|phi} in the text copy) is read as the coefficient of |phi'| phi' with phi' in rad/s, as its kg m^2 says "
        "(were it deg/s, the quadratic share of its Table 6 damping would still be below "
        f"{100 * _paper_share(_paper(), 'nls_svm', OMEGA0_BOUND) * 180 / math.pi:.1f} %).",
        "Errors (eq. 17-18): the identified model replayed by RK4 over the whole record from the release, "
        "in the same code for every method, from two starts named in every metric and row: "
        + "; ".join(f"`{k}` {v}" for k, v in STARTS.items()) + ".",
        "FLS and NLS-SVM also fit a constant heel offset and remove the 2nd-5th harmonics of the roll "
        "frequency from the equation rows before the least squares (the paper's eq. 15-16 are pointwise); "
        "NLS fits each record's initial state with the coefficients.",
    ]


def sections(runs: dict, out) -> list:
    cells = collect(runs)
    if not cells:
        return [("No runs", "The store holds no finished run of `experiment=roll_methods`.\n")]
    paper = _paper()
    found = claims(cells)
    result = [("Table 5 (section 5.1): known damping recovered", _table5(cells, paper)),
              ("Which errors the paper's Table 6 reports", _which_start())]
    for case in sorted({case for case, _ in cells if case != SIMULATED}):
        here = {m: cells.get((case, m)) for m in METHODS}
        if " + " in case:
            result.append((f"Table 6: `{case}`", "Identified on several records jointly: not compared with "
                                                 "Table 6, whose decay is one test.\n"))
            continue
        result.append((f"Table 6 (section 5.2): NLS, FLS and NLS-SVM, paper / `{case}`",
                       _table6(case, here, paper)))
    result.append(("The paper's claims, here, like for like", _claims_section(found)))
    result.append(("Disagreements and their causes", "\n".join(disagreements(cells, found)) + "\n"))
    result.append(("Tables 7 and 8 (section 5.3)", _tables78(paper)))
    return result
