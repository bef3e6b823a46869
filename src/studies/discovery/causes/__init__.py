"""The cause catalogue of ``studies discover`` (ids are the DESIGN.md contract).

A cause is a parameterised extension of the baseline that may explain what
the identified model misses; the protocol every cause follows (its id, what
it changes, its parameters and their no-effect values, how it is fitted,
its explanation) is :class:`~studies.discovery.causes.base.Cause`.

Modules: :mod:`.base` (the protocol, :class:`Setup`), one module per cause
(:mod:`.none`, :mod:`.rudder_offset`, :mod:`.current`, :mod:`.wind`,
:mod:`.environmental_bias`, :mod:`.missing_term`, :mod:`.propulsion`,
:mod:`.propeller_asymmetry`) and :mod:`.combined` (two
causes at once). The roll-decay causes (a linear roll model's missing
damping or restoring) are :mod:`.roll_decay`'s classes, in
``ROLL_CATALOGUE``.

Adding a cause
--------------
1. Write its module here: a subclass of :class:`Cause` with ``id``,
   ``params``, ``no_effect`` and ``explanation``, overriding only the hooks
   for what it changes (and ``bounds``/``scales`` for its fit).
2. Add the class to ``CATALOGUE`` below and, when discovery is to judge it,
   to :func:`manoeuvring_causes`; its id to DESIGN.md's table.
``tests/test_discover_causes.py`` then checks that it declares the protocol
and that its no-effect values leave a record unchanged.
"""

from __future__ import annotations

from .base import Cause, Setup, compact_parameters
from .combined import Combined
from .current import Current
from .environmental_bias import EnvironmentalBias
from .missing_term import MissingTerm, extended_library
from .none import NoCause
from .propeller_asymmetry import PropellerAsymmetry
from .propulsion import Propulsion
from .roll_decay import ROLL_CATALOGUE, RollCause
from .rudder_offset import RudderOffset
from .wind import WindSpeedBias, WindUnmodelled

__all__ = ["Setup", "Cause", "CATALOGUE", "catalogue_order", "pair_id", "manoeuvring_causes", "compact_parameters", "NoCause",
           "RudderOffset", "Current", "WindUnmodelled", "WindSpeedBias", "EnvironmentalBias",
           "MissingTerm", "Combined", "extended_library", "Propulsion", "PropellerAsymmetry", "RollCause", "ROLL_CATALOGUE"]

#: every manoeuvring cause by its contract id, ``none`` first
CATALOGUE = {c.id: c for c in (NoCause, RudderOffset, Current, WindUnmodelled, WindSpeedBias,
                               EnvironmentalBias, MissingTerm, Propulsion, PropellerAsymmetry)}


def catalogue_order(cause_id: str) -> int:
    """A cause's place in :data:`CATALOGUE` (after every cause when it is not in it)."""
    ids = list(CATALOGUE)
    return ids.index(cause_id) if cause_id in ids else len(ids)


def pair_id(first: str, second: str) -> str:
    """The verdict id of two causes acting together: their ids joined by ``+`` in catalogue order."""
    return "+".join(sorted([first, second], key=catalogue_order))


def manoeuvring_causes(ctx, missing_terms=()) -> list[Cause]:
    """The applicable manoeuvring causes, ``none`` first.

    Parameters
    ----------
    ctx : studies.discovery.fitting.Context
        The baseline model and the training records.
    missing_terms : sequence of Term
        The terms :class:`MissingTerm` adds (none: it is not applicable).
    """
    has_n0 = any(t.powers == (0, 0, 0, 0) for t in ctx.model.terms_of("N"))
    causes = [NoCause(), RudderOffset(), Current(), WindUnmodelled(), WindSpeedBias(),
              EnvironmentalBias(fit_moment=not has_n0), MissingTerm(missing_terms), Propulsion(),
              PropellerAsymmetry()]
    return [c for c in causes if c.applicable(ctx)]
