"""What the reproduction pages of :mod:`studies.report.reproduction` must compute beside the runs they read.

One module per paper: :mod:`.wang2021` (Wang et al. 2021, the SVM paper's
averaged models, MSS reference turn and disturbance sources) and
:mod:`.zhu2021` (the thesis: how well a condition's record pins each
coefficient down). The pages format; these simulate and identify.
"""
