"""``studies report`` pools the predictive bands of an experiment's runs.

Each run logs per validation record how much of the record its 50/80/90/95 %
bands hold; one record is close to all or nothing, so the report pools the
records per model and discrepancy setting and says whether the 90 % band is
overconfident, calibrated or wider than needed. The runs here are stored
runs as the store gives them back, with band metrics of known values.
"""

from __future__ import annotations

import numpy as np
import pytest

from studies.report.builder import build_report
from studies.report.calibration import band_rows, calibration_sentences, pooled_calibration


class _BandRun:
    """A finished ``method=bayes`` run with bands on its validation records."""

    def __init__(self, number: int, seed: int, model: str, discrepancy: bool, coverages: dict,
                 width: float = 200.0, extent: float = 3000.0, status: str = "FINISHED"):
        self.run_id = f"{number:032x}"
        self.name = f"bayes {model} seed={seed} disc={int(discrepancy)}"
        self.status, self.start_time = status, number
        self.params = {"seed": str(seed), "method.name": "bayes", "model.name": model,
                       "method.discrepancy": "process_noise" if discrepancy else "none"}
        self.tags = {}
        self.url = f"http://127.0.0.1:5000/#/experiments/1/runs/{self.run_id}"
        self.metrics = {}
        for record, levels in coverages.items():
            for level, value in zip((50, 80, 90, 95), levels):
                self.metrics[f"{record}/band/coverage_joint_{level}"] = value
            self.metrics.update({f"{record}/band/discrepancy": float(discrepancy),
                                 f"{record}/band/width_xy_m": width,
                                 f"{record}/band/width_over_extent": width / extent,
                                 f"{record}/band/trusted": float(0.8 <= levels[2] <= 0.97),
                                 f"{record}/band/covered_until_s": 100.0})

    def artifact(self, path, destination):
        return None


def _runs(plain, with_discrepancy, status="FINISHED"):
    runs = []
    for k, (a, b) in enumerate(zip(plain, with_discrepancy)):
        runs.append(_BandRun(2 * k, k, "mmg", False, {"zz_10": a[0], "tc_35": a[1]}))
        runs.append(_BandRun(2 * k + 1, k, "mmg", True, {"zz_10": b[0], "tc_35": b[1]}, status=status))
    return runs


PLAIN = [((0.1, 0.3, 0.4, 0.5), (0.0, 0.1, 0.2, 0.3)), ((0.2, 0.4, 0.5, 0.6), (0.1, 0.2, 0.3, 0.4))]
HONEST = [((0.5, 0.8, 0.9, 0.95), (0.4, 0.7, 0.85, 0.9)), ((0.6, 0.85, 0.95, 1.0), (0.5, 0.8, 0.9, 0.95))]


def test_records_are_pooled_per_model_and_discrepancy_setting():
    items = [{"run": r, "method": "bayes", "condition": r.params["seed"], "metrics": r.metrics,
              "status": r.status} for r in _runs(PLAIN, HONEST)]
    rows = band_rows(items)
    assert len(rows) == 8 and set(rows["record"]) == {"zz_10", "tc_35"}
    pooled = pooled_calibration(rows).set_index("discrepancy")
    assert pooled.loc[False, "records"] == 4 and pooled.loc[True, "records"] == 4
    assert pooled.loc[False, "coverage_90"] == pytest.approx(np.mean([0.4, 0.2, 0.5, 0.3]))
    assert pooled.loc[True, "coverage_90"] == pytest.approx(np.mean([0.9, 0.85, 0.95, 0.9]))
    assert pooled.loc[True, "records_within"] == 4 and pooled.loc[False, "records_within"] == 0
    plain, honest = calibration_sentences(pooled.reset_index().sort_values("discrepancy"))
    assert "model=mmg taken as exact" in plain and "overconfident" in plain and "35 %" in plain
    assert "model=mmg with its discrepancy" in honest and "calibrated at the 90 % level" in honest


def test_bands_that_always_hold_are_called_wider_than_needed_and_useless_when_wider_than_the_manoeuvre():
    wide = [_BandRun(1, 0, "abkowitz", True, {"zz_20": (1.0, 1.0, 1.0, 1.0)}, width=5000.0, extent=3000.0)]
    items = [{"run": r, "method": "bayes", "condition": "0", "metrics": r.metrics, "status": r.status}
             for r in wide]
    (sentence,) = calibration_sentences(pooled_calibration(band_rows(items)))
    assert "conservative" in sentence and "wider than the manoeuvre itself" in sentence


def test_the_report_page_has_the_calibration_table_figure_and_verdicts(tmp_path):
    runs = _runs(PLAIN, HONEST) + [_BandRun(9, 9, "mmg", True, {"zz_10": (0, 0, 0, 0)}, status="FAILED")]
    page = build_report("bands", runs, tmp_path, condition="seed")
    text = page.read_text()
    section = text.split("## Predictive bands and their calibration", 1)[1]
    assert (page.parent / "calibration.png").is_file() and "![calibration](calibration.png)" in section
    assert section.count("| bayes mmg seed=") == 8          # the failed run's record is not counted
    assert "over 4 validation records" in section and "overconfident" in section
    assert "calibrated at the 90 % level" in section


def test_runs_without_bands_have_no_calibration_section(tmp_path):
    run = _BandRun(1, 0, "mmg", False, {})
    page = build_report("nobands", [run], tmp_path)
    assert "Predictive bands" not in page.read_text()


def test_roll_decay_bands_are_pooled_on_their_own_with_widths_in_degrees():
    run = _BandRun(1, 0, "roll", True, {})
    run.metrics = {"decay_2/band/coverage_50": 0.52, "decay_2/band/coverage_80": 0.73,
                   "decay_2/band/coverage_90": 0.79, "decay_2/band/coverage_95": 0.81,
                   "decay_2/band/discrepancy": 1.0, "decay_2/band/width_deg": 1.37,
                   "decay_2/band/width_over_amplitude": 0.13, "decay_2/band/trusted": 0.0}
    manoeuvre = _BandRun(2, 0, "mmg", True, {"zz_10": (0.5, 0.8, 0.9, 0.95)})
    items = [{"run": r, "method": "bayes", "condition": "0", "metrics": r.metrics, "status": r.status}
             for r in (run, manoeuvre)]
    pooled = pooled_calibration(band_rows(items))
    assert sorted(pooled["what"]) == ["roll angle phi(t)", "track (x0, y0), joint band"]
    roll = next(s for s in calibration_sentences(pooled) if s.startswith("roll"))
    assert "over 1 validation record the" in roll and "79 %" in roll and "1.37 deg" in roll
    assert "overconfident" in roll
