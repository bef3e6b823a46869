"""Roll decay, the whole feature: one-degree-of-freedom free roll decay (Chen et al., 2019).

The model, divided by the total roll inertia ``I = I_xx + A_44``::

    phi'' + b1 phi' + b2 |phi'| phi' [+ b3 phi'^3] + omega0^2 phi [+ c3 phi^3] = 0

with the roll angle ``phi`` [rad] about equilibrium, the natural frequency
``omega0`` [rad/s], linear damping ``b1`` [1/s], quadratic damping ``b2`` [-],
cubic damping ``b3`` [s] and cubic restoring ``c3`` [1/s^2] (angles in
radians). The terms in brackets are optional; the coefficients are equivalent
coefficients at the natural frequency (the memory-effect convolution of the
paper is absorbed into them, see :mod:`studies.roll.model`).

Modules
-------
model
    :class:`~studies.roll.model.RollModel` (terms, right-hand side,
    regressors and the one RK4 integrator, numba-compiled), equivalent linear
    damping, Froude scaling of coefficients, dimensional coefficients.
estimators
    Identification: NLS (output error), FLS (smoothing spline, equation
    error) and NLS-SVM (LS-SVM, equation error); ``make_estimator``.
bayes
    ``method=bayes``: emcee posterior of the coefficients and initial states
    on the output-error likelihood with an AR(2) residual estimated jointly
    (:class:`~studies.roll.bayes.BayesRollEstimator`).
discrepancy
    The model discrepancy of the predictive bands: Ornstein-Uhlenbeck wander
    of the roll stiffness and linear damping, estimated by the prediction-error
    method with a compiled extended Kalman filter on the training decays.
bands
    Posterior predictive bands of a decay and of its peak envelope, their
    calibration (coverage at 50/80/90/95 %, width, interval score, CRPS) and
    whether they can be trusted.
methods
    Every roll method by its ``method=`` name (``ROLL_METHODS``, ``make_method``).
lssvm
    Least-squares support-vector regression with RBF kernel and its analytic
    derivatives, windowed fits, cross-validation (used by NLS-SVM).
records
    Roll-decay records: reading the supported CSV formats, release detection,
    offset removal, resampling, refusal of non-decays, the initial state, Froude
    scaling of a record's time, ship particulars, a record's forward speed and
    vessel, the split into first and later cycles.
simulate
    Simulated decays: a record predicted from its initial state
    (``predict_record``) and synthetic decay records (``simulate_decay_record``).
decay
    Decay analysis: extrema, period, noise level, decay curve (decrement per
    half-cycle) and its least-squares fit.
speed
    Damping against forward speed, ``b1(U) = b1_0 + b1_U U`` with ``b2`` per
    speed, fitted to decays at two or more speeds; a decay simulated at an
    untested speed.
comparison
    Prediction errors (MAE, RMSE) of a decay replayed from a given start,
    the same for every method (``replay_errors``; ``STARTS``: the record's
    own initial state or the method's), and the damping of a simulated decay
    against measured ones.
figures
    PNG figures: predictions and errors, decay curves, simulation vs tests,
    peak envelopes.
workflow
    The roll-decay kind of study behind the command line: ``studies run``
    (:mod:`~studies.roll.workflow.run` prepares, :mod:`~studies.roll.workflow.pipeline`
    identifies, compares, draws and logs) and ``studies discover``
    (:mod:`~studies.roll.workflow.discover`, the causes fitted and named by
    :mod:`~studies.roll.workflow.search`). It sits in the workflows' layer: it
    may use discovery and the run bookkeeping, the modules above may not use it.

The roll-decay causes are classes of the one cause catalogue,
:mod:`studies.discovery.causes.roll_decay`.

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479.
https://doi.org/10.1016/j.oceaneng.2019.106479
"""
