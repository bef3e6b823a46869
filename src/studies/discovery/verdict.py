"""What ``studies discover`` concludes, as one typed value: :class:`Discovery`.

``discovery.json`` is :meth:`Discovery.to_dict` (the DESIGN.md contract:
``cause``, ``parameters``, ``uncertainty``, ``baseline``, ``extended``,
``gain_pct``, ``ranking``, ``confidence``, ``undecided``,
``next_manoeuvre``), plus what a model-test engineer needs to decide whether
to trust it: each parameter's unit and convention, the values the extension
uses without fitting them, the probability that each cause acts, and how the
verdict was reached.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

__all__ = ["Discovery"]


@dataclass
class Discovery:
    """The verdict of one discovery.

    Attributes
    ----------
    cause : str
        The named cause's id, a pair ``"a+b"`` or ``"none"`` (DESIGN.md's catalogue).
    parameters : dict
        Its fitted parameters (a pair: by cause id); units in ``parameter_units``.
    parameter_units : dict
        Each parameter's unit and convention, shaped as ``parameters``.
    fixed_parameters : dict
        Values the extension uses but does not fit (published ones).
    uncertainty : dict
        90 % intervals of the parameters, shaped as ``parameters``.
    confidence : float
        Posterior probability that the named verdict is the right one (0-1).
    confidence_basis : str
        How ``confidence`` was computed, in words.
    inclusion : dict
        ``{cause id: share of the bootstrap reweightings that name it}`` (alone or in a pair).
    ranking : list of dict
        Every verdict compared: ``cause``, ``probability`` (share of the
        bootstrap reweightings that name it), ``gain`` (held-out
        log-likelihood gain over ``none``, summed over the blocks), ``score``
        (``-2 ln`` of its probability relative to the most probable verdict:
        0 for it, lower is better).
    undecided : list of str or None
        When the verdict's probability is below 0.9: the named verdict, then the
        rivals the records cannot tell from it.
    next_manoeuvre : str or None
        What would separate them.
    baseline, extended : dict
        ``validation_rmse`` (position error of the whole held-out records
        replayed [m], pooled over them), ``validation_rmse_windowed`` (the
        windowed error, replays from each window's state: the dynamics a few
        minutes ahead), ``training_rmse`` (windowed, on the training records)
        of the baseline and of the named extension.
    gain_pct : float
        What the extension gains on the whole held-out records [%]
        (``100 (1 - extended / baseline)`` of ``validation_rmse``; negative: it
        predicts them worse; reported, never a reason to name).
    explains_validation : bool
        Whether the named model explains the held-out records: its windowed
        error there is not many times its own training error, and it is no
        worse than the baseline on the whole records (beyond ``gain_interval_pct``)
        or on any characteristic (``held_out``).
    gain_interval_pct : list or None
        90 % interval of ``gain_pct`` (moving-block bootstrap of the replays'
        errors: :mod:`studies.discovery.held_out`).
    gain_windowed_pct : float or None
        The gain in the windowed error (secondary).
    held_out : dict
        ``characteristics``: per held-out record the advance, tactical
        diameter [m] or overshoots [deg] measured and each model's error,
        ``worse``: what the extension predicts worse than the baseline.
    outside_training : dict or None
        Where the held-out records leave the training records' states and how
        much of the baseline's departure lies there
        (:mod:`studies.discovery.training_states`); the verdict is
        ``outside_training_states`` when most of it does and no extension
        predicts them better.
    inference_verdict : str or None
        What the inference over the catalogue named on the training records
        (differs from ``cause`` when that is ``outside_training_states``).
    look_alikes : list or None
        Written as ``class``: the verdicts the records cannot tell from the
        named one, the named first (:mod:`studies.discovery.look_alike`); one
        member when the records separate it from every rival; None for
        ``none``. ``confidence`` is then the class's probability. With
        ``outside_training_states``, the class of what the inference named
        on the training records (``inference_verdict``).
    class_parameters : dict
        ``{member: parameters}`` of the class's members (units: each cause's
        ``units`` in the catalogue; a pair's by cause id).
    class_probability : float or None
        Probability that the records' verdict is one of the class.
    class_evidence : dict
        ``evidence``: ``{rival: the records' evidence for the named verdict
        over it}``, ``threshold`` (at or above it the rival is told apart) and
        ``measure`` (what the evidence is).
    detection_limits : dict
        ``{cause id: parameters}``: the smallest effect of each cause these
        records would show, in the direction it was fitted (its
        ``candidates`` entry scaled until its evidence over none reaches the
        naming threshold; units as the cause's); None where its fit explains
        nothing to scale. Given beside every verdict, ``none`` included.
    detection_units : dict
        ``{cause id: {parameter: unit}}``.
    settling : dict or None
        For a class of more than one member: the standard manoeuvre that would
        tell its members apart best, computed by simulating every member
        (:mod:`studies.discovery.settling`): ``manoeuvre``, ``evidence``
        (``{rival: expected evidence}``, twice a log-likelihood ratio),
        ``needed``, ``menu`` (every manoeuvre's), ``noise``, ``correlation_s``.
    explanation : str
        The named cause's physical explanation.
    baseline_model : str
        The baseline model (``abkowitz``, ``symmetric``, ``mmg``, ...).
    scale : str
        The records' scale (``full`` or ``model``), in which every dimensional value is given.
    method : str
        How the verdict was reached.
    units : str
        Unit of the validation errors.
    notes : list of str
    seconds : dict
        Time spent per stage [s].
    candidates : dict
        ``{cause id: parameters}`` of every single cause refined on these
        records, named or not: what each would be if it acted (e.g. the
        basin's own small rudder asymmetry on a verdict of ``none``).
    candidates_beside : dict
        ``{cause id: parameters}`` of every other single cause refined beside
        a named single cause: what each would be if it acted as well.
    evidence : dict
        ``margin``: ``{cause or pair: how far it is towards being named}`` (a
        pair's: its second cause's beside the first), ``measure``: what the
        margin is (on the tracks, the BIC score over ``none``; with block
        cross-validation, the held-out gain over its standard error), and
        ``threshold``/``second_threshold``: the margin naming needs.
    departures : list of dict
        Where the whole replays (baseline, extended, another simulator's run
        given by ``simulation.path``) depart most from the held-out records:
        per model its largest departures by phase and state.
    alike : dict
        ``{cause id: {other cause id: {"correlation", "variant", "as"}}}``: how
        alike two causes' signatures are on these records (first canonical
        correlation, the baseline's coefficients projected out; 1: the
        records cannot tell them apart whatever the noise, 0: nothing in
        common), at the variants most alike (:mod:`studies.discovery.alike`).
    injected : dict or None
        With ``discover.injected``: the stated effect's own score on these
        records at its stated parameters (:mod:`.stated_effect`; ``score``
        below 0: the records cannot show it to this criterion).
    splits : list of dict
        With ``discover.splits``: every record held out in turn, the baseline
        and the named model identified on the others (``held_out``,
        ``parameters``, ``baseline_validation_rmse``,
        ``extended_validation_rmse``, ``gain_pct``, ``training_rmse``,
        ``explains_validation``, ``diverges``).
    """

    cause: str
    parameters: dict
    parameter_units: dict
    fixed_parameters: dict
    uncertainty: dict
    confidence: float
    confidence_basis: str
    inclusion: dict
    ranking: list
    baseline: dict
    extended: dict
    gain_pct: float
    explains_validation: bool
    explanation: str
    baseline_model: str
    scale: str
    method: str
    undecided: list | None = None
    next_manoeuvre: str | None = None
    units: str = "m (position RMSE of the whole held-out records replayed)"
    notes: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)
    departures: list = field(default_factory=list)
    candidates: dict = field(default_factory=dict)
    evidence: dict = field(default_factory=dict)
    candidates_beside: dict = field(default_factory=dict)
    #: every record held out in turn (``discover.splits``): the named model's gain on each
    splits: list = field(default_factory=list)
    #: the stated effect's own score (``discover.injected``)
    injected: dict | None = None
    #: how alike the causes' signatures are on these records
    alike: dict = field(default_factory=dict)
    gain_interval_pct: list | None = None
    gain_windowed_pct: float | None = None
    held_out: dict = field(default_factory=dict)
    outside_training: dict | None = None
    inference_verdict: str | None = None
    look_alikes: list | None = None
    class_parameters: dict = field(default_factory=dict)
    class_probability: float | None = None
    class_evidence: dict = field(default_factory=dict)
    detection_limits: dict = field(default_factory=dict)
    detection_units: dict = field(default_factory=dict)
    settling: dict | None = None

    def to_dict(self) -> dict:
        """The value written to ``discovery.json`` (``look_alikes`` as ``class``, DESIGN.md)."""
        out = asdict(self)
        out["class"] = out.pop("look_alikes")
        return out
