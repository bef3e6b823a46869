"""``studies simulate``: one manoeuvre of an identified (or published) model.

The manoeuvre is simulated as a run's validation simulates it
(:meth:`IdentifiedModel.simulate`), beside the model the run compared
against (the vessel's published coefficients, when it has them), and the
files are those of a run's validation
(:func:`studies.workflows.manoeuvring.compare_simulated`):

- ``metrics.json``: ``<manoeuvre>/...``: the characteristics (overshoot
  angles [deg]; advance, transfer, tactical diameter [m]) and, against the
  reference, their ``..._reference`` values and errors
  (``..._error_pct``, ``..._error_deg``), fitness (thesis eq. 3.43),
  ``rmse_u|v|r``, ``mae_*``, ``diverged``;
- ``validation_<manoeuvre>.png``: trajectory and time series, and
  ``validation_<manoeuvre>.csv``: the overlay's time series (with a
  reference);
- ``simulation_<manoeuvre>.csv``: the simulated record itself (data
  contract, every sample), which ``studies run data.path=`` reads.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..simulate import Manoeuvre
from .identified_model import IdentifiedModel
from .manoeuvring import compare_simulated

__all__ = ["simulate_model"]


def simulate_model(identified: IdentifiedModel, manoeuvre: Manoeuvre, out_dir: Path, label: str,
                   against_reference: bool = True) -> dict:
    """Simulate ``manoeuvre`` with ``identified`` and write the files into ``out_dir``.

    ``label`` names the model in the figure's title (its URI);
    ``against_reference=False`` leaves the reference out (the published
    model is its own reference). Returns the metrics (also ``metrics.json``).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    name = manoeuvre.name
    pred = identified.simulate(manoeuvre)
    reference = identified.reference() if against_reference else None
    ref = reference.simulate(manoeuvre) if reference is not None else None
    title = f"{name}: {label}" + (" vs reference model" if ref is not None else "")
    metrics = compare_simulated(name, manoeuvre, pred, ref, out_dir, title)
    pred.to_csv(out_dir / f"simulation_{name}.csv", index=False)
    metrics = {k: float(v) for k, v in metrics.items()}
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=1, sort_keys=True))
    return metrics
