"""The roll-decay kind of study: what ``studies run`` and ``studies discover`` do with roll decays.

- :mod:`.run`: a run's settings made into a prepared run (records read once, vessel, scale);
- :mod:`.pipeline`: identification, method comparison, bands, figures and metrics of a run;
- :mod:`.discover`: ``studies discover`` on decays;
- :mod:`.search`: every roll cause (:mod:`studies.discovery.causes.roll_decay`) fitted, scored and named.

This package belongs to the workflows' layer (``tests/test_architecture.py``), above
:mod:`studies.discovery`; the rest of :mod:`studies.roll` lies below it.
"""
