"""What `studies run` and `studies discover` print when they end: the result in words and
numbers with their units, as the docs describe it. The files keep every number in full.

A run prints what was identified, how far from the true coefficients when
the data were simulated from a known model, and each validation manoeuvre
or record with its errors (fitness of thesis eq. 3.43, position RMSE [m],
advance and tactical diameter errors [%], overshoot errors [deg], roll
angle RMSE [deg]), the training manoeuvre marked. A discovery prints the
verdict, its confidence, the parameters in their units, the held-out
prediction error of the baseline and of the extended model and the records'
scale.
"""

from __future__ import annotations

import math

from .formatting import compact_parameters, number

__all__ = ["run_lines", "discovery_lines", "number"]

#: per record: (metric, label, unit), printed in this order when the run has it
RECORD_QUANTITIES = (
    ("fitness", "fitness", ""),
    ("rmse_position", "position RMSE", "m"),
    ("advance_error_pct", "advance", "%"),
    ("tactical_diameter_error_pct", "tactical diameter", "%"),
    ("overshoot1_error_deg", "1st overshoot", "deg"),
    ("overshoot2_error_deg", "2nd overshoot", "deg"),
    ("closed_loop/overshoot1_error_deg", "1st overshoot run as the test", "deg"),
    ("closed_loop/overshoot2_error_deg", "2nd overshoot run as the test", "deg"),
    ("rmse_deg_record_start", "roll RMSE from the record's start", "deg"),
    ("rmse_deg_own_start", "from the fitted start", "deg"),
)

#: units of the identified roll coefficients
ROLL_UNITS = {"omega0": "rad/s", "b1": "1/s", "b2": "-", "b3": "s", "c3": "1/s^2"}


def _records(metrics: dict) -> list[str]:
    """The validation records or manoeuvres of a run, in the order their metrics came."""
    names = []
    for key in metrics:
        head, _, tail = key.partition("/")
        if tail and head not in names and any(tail == q for q, _, _ in RECORD_QUANTITIES):
            names.append(head)
    return [n for n in names if n not in ("training", "fit", "validation")]


def run_lines(metrics: dict, training: set | None = None) -> list[str]:
    """The end of a `studies run`: what was identified and how it predicts."""
    lines = []
    identify_s, total_s = metrics.get("runtime/identify_s"), metrics.get("runtime/total_s")
    if identify_s is not None:
        lines.append(f"identified in {number(identify_s)} s"
                     + (f" (the whole run {number(total_s)} s)" if total_s is not None else ""))
    coefficients = {k.split("/", 1)[1]: v for k, v in metrics.items() if k.startswith("coef/")}
    if coefficients:
        lines.append("identified: " + ", ".join(f"{k} = {number(v)} {ROLL_UNITS.get(k, '-')}".rstrip(" -")
                                                 for k, v in coefficients.items()))
    if "deviation/median_abs_pct" in metrics:
        lines.append("coefficients against the true ones: median |deviation| "
                     f"{number(metrics['deviation/median_abs_pct'])} %, largest "
                     f"{number(metrics.get('deviation/max_abs_pct'))} %")
    records = _records(metrics)
    training = set(training or ())
    training |= {n for n in records if metrics.get(f"{n}/is_training")}
    if records:
        held = [n for n in records if n not in training]
        diverged = sum(1 for n in records if metrics.get(f"{n}/diverged") or metrics.get(f"{n}/diverged_record_start"))
        lines.append(f"predicted by the identified model: {len(held)} manoeuvre(s) or record(s) not trained on"
                     + (f" and {len(records) - len(held)} trained on" if len(held) < len(records) else "")
                     + f", {diverged} diverged"
                     + (" (fitness: thesis eq. 3.43, 0 is exact)" if any(f"{n}/fitness" in metrics
                                                                          for n in records) else "") + ":")
        width = max(len(n) for n in records)
        for name in records:
            parts = []
            for key, label, unit in RECORD_QUANTITIES:
                value = metrics.get(f"{name}/{key}")
                if value is not None:
                    sign = "+" if unit in ("%", "deg") and key.endswith(("_pct", "error_deg")) and value > 0 else ""
                    parts.append(f"{label} {sign}{number(value)}{(' ' + unit) if unit else ''}")
            mark = "   (trained on)" if name in training else ""
            lines.append(f"  {name:<{width}}  {', '.join(parts)}{mark}")
    if "validation/mae_speed" in metrics:
        lines.append(f"mean speed error over the {number(metrics.get('validation/validated'))} manoeuvres not "
                     f"trained on: {number(metrics['validation/mae_speed'])} m/s")
    if "cpu_s" in metrics and identify_s is None:
        lines.append(f"identified in {number(metrics['cpu_s'])} s of CPU")
    return lines


def _parameter(name: str, value, unit: str | None) -> str:
    """A cause's parameter in its catalogue units, angles in radians also in degrees."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if unit == "rad" or (unit is None and name in ("direction", "delta0")):
            return f"{name} = {number(value)} rad ({number(math.degrees(value))} deg)"
        if unit is None and name == "speed":
            unit = "m/s"
        return f"{name} = {number(value)}" + (f" {unit}" if unit and unit != "-" else "")
    if isinstance(value, dict):
        return f"{name}: " + ", ".join(f"{k} = {number(v)}" for k, v in value.items())
    return f"{name} = {value}"


def _limit(name: str, value, unit: str | None) -> str:
    """A detection limit's parameter: its size, angles in degrees, other units as the catalogue's first word."""
    if isinstance(value, dict):
        prime = " (prime)" if "prime" in (unit or "") else ""
        return ", ".join(f"{k} = {number(abs(v))}{prime}" for k, v in value.items())
    short = (unit or "").split(",")[0].split(";")[0].strip()
    if short == "rad" or name == "delta0":
        return f"{name} = {number(abs(math.degrees(value)))} deg"
    if short == "-" and "prime" in (unit or ""):
        short = "(prime)"
    return f"{name} = {number(abs(value))}" + (f" {short}" if short and short != "-" else "")


def discovery_lines(discovery: dict) -> list[str]:
    """The end of a `studies discover`: the verdict, its confidence, units, the gain, the scale."""
    cause = discovery.get("cause")
    confidence = discovery.get("confidence")
    members = discovery.get("class") or []
    one_of = len(members) > 1 and cause != "outside_training_states"
    head = f"verdict: {cause}" + (" (the most probable of a class the records cannot tell apart)" if one_of else "")
    if isinstance(confidence, (int, float)):
        head += f" (confidence {number(confidence)}" + (", the class's)" if one_of else ")")
    elif isinstance(discovery.get("outside_training"), dict):
        share = discovery["outside_training"].get("departure_share")
        head += (f" (a measurement, not a probability: {number(100 * share)} % of the departure from the "
                 "held-out records lies beyond the training records' states)")
    lines = [head]
    parameters = discovery.get("parameters") or {}
    uncertainty = discovery.get("uncertainty") or {}
    units = discovery.get("parameter_units") or {}
    for name, value in (parameters.items() if cause != "outside_training_states" else ()):
        text = "  " + _parameter(name, value, units.get(name))
        interval = uncertainty.get(name)
        if isinstance(interval, (list, tuple)) and len(interval) == 2:
            text += f", 90 % interval [{number(interval[0])}, {number(interval[1])}]"
        lines.append(text)
    members = discovery.get("class") or []
    if len(members) > 1:
        what = "it" if one_of else f"{members[0]}, which the inference on the training records named,"
        lines.append(f"  the records cannot tell {what} from {', '.join(members[1:])} (one class, probability "
                     f"{number(discovery.get('class_probability'))}; each member's fit in discovery.json)")
        params = discovery.get("class_parameters") or {}
        for member in members[1:]:
            if params.get(member):
                lines.append(f"    {member}: {compact_parameters(params[member])}")
    if one_of and discovery.get("next_manoeuvre"):
        lines.append(f"  to tell them apart: {discovery['next_manoeuvre']}")
    limits = {cid: p for cid, p in (discovery.get("detection_limits") or {}).items() if p}
    if limits:
        units = discovery.get("detection_units") or {}
        lines.append("smallest effect these records would show: " + "; ".join(
            f"{cid} " + ", ".join(_limit(name, value, (units.get(cid) or {}).get(name)) for name, value in p.items()
                                  if value is not None and name != "direction")
            for cid, p in limits.items()))
    second = (discovery.get("second_cause") or {}).get("cause")
    if second:
        lines.append(f"  a second cause on top: {second}")
    baseline = (discovery.get("baseline") or {}).get("validation_rmse")
    extended = (discovery.get("extended") or {}).get("validation_rmse")
    unit = str(discovery.get("units") or "").split(" (")[0] or "m"
    if baseline is not None and cause in ("none", "outside_training_states"):
        lines.append(f"held-out prediction error of the model as identified: {number(baseline)} {unit} "
                     "(no extension named)")
    elif baseline is not None and extended is not None:
        interval = discovery.get("gain_interval_pct")
        shown = f" (90 % interval {number(interval[0])} to {number(interval[1])} %)" if interval else ""
        lines.append(f"held-out prediction error: baseline {number(baseline)} {unit}, extended "
                     f"{number(extended)} {unit}: gain {number(discovery.get('gain_pct'))} %{shown}")
    worse = (discovery.get("held_out") or {}).get("worse")
    if worse and cause != "none":
        lines.append(f"  the extension predicts worse: {'; '.join(worse)}")
    beyond = discovery.get("outside_training")
    if isinstance(beyond, dict) and cause == "outside_training_states":
        for state in beyond.get("states", {}).values():
            lines.append(f"  {state['meaning']}: {number(state['held_out'][0])} to {number(state['held_out'][1])} "
                         f"{state['unit']} held out, {number(state['training'][0])} to "
                         f"{number(state['training'][1])} in training".replace(" - ", " "))
        lines.append(f"  would cover them: {beyond.get('manoeuvre')}")
        if discovery.get("inference_verdict"):
            lines.append(f"  (the inference on the training records alone named {discovery['inference_verdict']})")
    scale = discovery.get("scale")
    if isinstance(scale, str) and scale:
        lines.append(f"records studied at {scale} scale")
    return lines
