"""Every identification method, by kind of study and ``method=`` name: the one registry.

Manoeuvring models are identified by the estimators of :mod:`studies.identification`
(``ls``, ``svm``, ``ls_ga``, ``svm_ga``, ``bayes``, ``sindy``), roll decays by
those of :mod:`studies.roll.methods` (``nls``, ``fls``, ``nls_svm``,
``bayes``). A run checks its method here once, before anything is read or
tracked; a method of the other kind is refused with the setting that runs it.
"""

from __future__ import annotations

from ..errors import ConfigError
from ..identification import MANOEUVRING_METHODS
from ..roll.methods import ROLL_METHODS

__all__ = ["METHODS", "check_method"]

#: ``{kind of study: {method name: estimator class}}``
METHODS = {"manoeuvring": MANOEUVRING_METHODS, "roll_decay": ROLL_METHODS}

#: the model setting that selects each kind, for the refusal's hint
_KIND_MODELS = {"manoeuvring": "model=abkowitz (or symmetric, simplified, mmg)", "roll_decay": "model=roll"}


def check_method(kind: str, name: str) -> None:
    """Refuse (:class:`~studies.errors.ConfigError`, one line) a method that ``kind`` does not
    have, naming the ones it has and, for a method of another kind, the model setting for it."""
    if name in METHODS[kind]:
        return
    other = [k for k, methods in METHODS.items() if k != kind and name in methods]
    hint = f" ('{name}' identifies {other[0].replace('_', ' ')} studies: {_KIND_MODELS[other[0]]})" if other else ""
    raise ConfigError(f"method '{name}' is not available for {kind.replace('_', ' ')} studies; "
                      f"known: {', '.join(sorted(METHODS[kind]))}{hint}")
