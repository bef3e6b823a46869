"""What is measured on simulated or identified results.

- :mod:`~studies.analysis.metrics`: prediction errors (fitness of thesis
  eq. 3.43, MAE/RMSE per state, position error), divergence penalty;
- :mod:`~studies.analysis.characteristics`: manoeuvre characteristics
  (zig-zag overshoots, turning-circle advance, transfer, tactical diameter,
  steady turn);
- :mod:`~studies.analysis.correlation`: Spearman correlation groups of
  repeated estimates (Li et al. 2023);
- :mod:`~studies.analysis.pawn`: PAWN sensitivity of the trajectory to each
  coefficient (SALib);
- :mod:`~studies.analysis.bands`: posterior predictive bands of a replayed
  record (coefficient draws and model discrepancy) and their calibration
  (coverage per nominal level, width, interval score, CRPS).
"""
