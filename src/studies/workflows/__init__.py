"""The pipelines behind the command line, one per kind of study.

- :mod:`~studies.workflows.protocol`: the StudyKind protocol the command line uses;
- :mod:`~studies.workflows.kinds`: the kinds of study by ``model.study``;
- :mod:`~studies.workflows.manoeuvring` (+ :mod:`~studies.workflows.measured`
  for measured records): ``studies run`` on manoeuvring records;
- :mod:`~studies.workflows.discover`: ``studies discover`` on manoeuvring records;
- roll decays have one home, :mod:`studies.roll` (its pipelines in
  :mod:`studies.roll.workflow`);
- :mod:`~studies.workflows.simplify`: ``studies simplify`` (Li et al. 2023);
- :mod:`~studies.workflows.settings`: what a study derives from its settings.
"""
