"""Standard and less-excitation manoeuvres, as rudder programmes.

A :class:`Manoeuvre` says what the helmsman (or autopilot) does; the
simulator turns it into a rudder mode of :mod:`studies.simulate.integrator`.
Angles in configs are degrees (what people write), radians inside.

Kinds
-----
``zigzag``
    IMO zig-zag ``amplitude/heading``: rudder to ``first_sign * amplitude``,
    reversed each time the heading has changed by ``heading`` in the
    direction the rudder drives it.
``turning``
    Rudder to ``amplitude`` and held; pull-out (rudder to zero) once the
    heading has changed by ``heading`` degrees (0: no pull-out).
``course``
    Heading autopilot (PD) following a piecewise-constant heading
    reference ``schedule = [[t_start, t_end, heading_deg], ...]`` (zero
    elsewhere): the zig-zag-like and random tests of Li et al. (2023),
    Table 4.
``rudder``
    Piecewise-constant commanded rudder ``schedule`` (zero elsewhere), e.g.
    the circle test (20 deg for 600 s); or an arbitrary commanded rudder
    time series ``series = [[t, delta_deg], ...]`` (linear in between), given
    inline or as ``series_file``, a CSV with columns ``t`` [s] and ``delta``
    [deg].

References
----------
IMO (2002). Standards for ship manoeuvrability, MSC.137(76).

Li, S., Wang, T., Li, G., Skulstad, R., Zhang, H. (2023). Ship maneuvering
model optimization for improved identification with less excitation. Ocean
Engineering 281, Table 4.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..data.io import read_table
from ..errors import ConfigError, DataError

__all__ = ["Manoeuvre", "MANOEUVRE_KINDS", "zigzag", "turning", "zigzag_of_record"]

MANOEUVRE_KINDS = ("zigzag", "turning", "course", "rudder")


@dataclass(frozen=True)
class Manoeuvre:
    """A manoeuvre to simulate.

    Attributes
    ----------
    name : str
        Record name (``zigzag_20_20``, ...), used as metric prefix.
    kind : str
        One of :data:`MANOEUVRE_KINDS`.
    duration : float
        Length of the record [s].
    dt : float
        Sampling interval of the record [s]; the integration step is
        ``dt / substeps`` with ``substeps`` chosen so it is at most
        ``max_step``.
    amplitude : float
        Rudder amplitude [deg] (zigzag, turning).
    heading : float
        Heading change that reverses the rudder (zigzag) or starts the
        pull-out (turning) [deg].
    first_sign : int
        Sign of the first rudder deflection (zigzag, turning).
    execute : float
        Time [s] the first rudder command is given (zigzag, turning); before
        it the rudder is held amidships, as MSS ``zigzag.m`` does until its
        ``t_rudderexecute`` (it lays the rudder when ``round(t)`` reaches
        that time: ``t_rudderexecute - 0.5`` s at a 0.1 s step).
    schedule : tuple of (t_start, t_end, value_deg)
        Heading reference (course) or commanded rudder (rudder) segments.
    kp, kd : float
        Autopilot gains: rudder [rad] per heading error [rad], and per yaw
        rate [rad/s] (so ``kd`` is in seconds).
    max_step : float
        Largest integration step [s].
    """

    name: str
    kind: str
    duration: float
    dt: float = 0.1
    amplitude: float = 20.0
    heading: float = 20.0
    first_sign: int = 1
    execute: float = 0.0
    schedule: tuple = field(default_factory=tuple)
    series: tuple = field(default_factory=tuple)
    kp: float = 1.0
    kd: float = 10.0
    max_step: float = 0.1

    def __post_init__(self):
        if self.kind not in MANOEUVRE_KINDS:
            raise ConfigError(f"manoeuvre '{self.name}': unknown kind '{self.kind}' "
                              f"(known: {', '.join(MANOEUVRE_KINDS)})")
        if not (self.duration > 0):
            raise ConfigError(f"manoeuvre '{self.name}': duration must be positive, got {self.duration}")
        if not (0 < self.dt <= self.duration):
            raise ConfigError(f"manoeuvre '{self.name}': dt must be in (0, duration], got {self.dt}")
        if self.kind in ("zigzag", "turning") and not (0 < abs(self.amplitude) <= 90):
            raise ConfigError(f"manoeuvre '{self.name}': rudder amplitude must be in (0, 90] deg")
        if self.kind == "zigzag" and not (self.heading > 0):
            raise ConfigError(f"manoeuvre '{self.name}': zig-zag heading must be positive")
        if not (0.0 <= self.execute < self.duration):
            raise ConfigError(f"manoeuvre '{self.name}': execute time must be in [0, duration), "
                              f"got {self.execute}")

    @property
    def substeps(self) -> int:
        return max(1, int(np.ceil(self.dt / self.max_step - 1e-9)))

    @property
    def step(self) -> float:
        """Integration step [s]."""
        return self.dt / self.substeps

    def sample_times(self) -> np.ndarray:
        n = int(round(self.duration / self.dt))
        return np.arange(n + 1) * self.dt

    def step_times(self) -> np.ndarray:
        n = int(round(self.duration / self.dt)) * self.substeps
        return np.arange(n + 1) * self.step

    def schedule_values(self, times: np.ndarray) -> np.ndarray:
        """Piecewise-constant schedule [rad] at ``times`` (zero outside segments)."""
        out = np.zeros_like(times, dtype=float)
        for t0, t1, value in self.schedule:
            out[(times >= t0) & (times < t1)] = np.deg2rad(value)
        return out

    def rudder_programme(self, yaw_sign: float):
        """(mode, cmd per integration step, params) for the compiled integrator."""
        times = self.step_times()
        params = np.zeros(4)
        # zigzag and turning: 1 from the execute time on (half a step's tolerance for the grid)
        executed = (times >= self.execute - 0.5 * self.step).astype(float)
        if self.kind == "zigzag":
            params[:] = [np.deg2rad(self.amplitude), np.deg2rad(self.heading), yaw_sign,
                         float(np.sign(self.first_sign) or 1)]
            return 1, executed, params
        if self.kind == "turning":
            params[:3] = [np.deg2rad(self.amplitude) * (np.sign(self.first_sign) or 1),
                          np.deg2rad(self.heading), yaw_sign]
            return 4, executed, params
        if self.kind == "course":
            params[:3] = [self.kp, self.kd, yaw_sign]
            return 2, self.schedule_values(times), params
        if self.series:
            pts = np.asarray(self.series, dtype=float)
            return 0, np.deg2rad(np.interp(times, pts[:, 0], pts[:, 1])), params
        return 0, self.schedule_values(times), params

    @classmethod
    def from_config(cls, cfg) -> "Manoeuvre":
        """Build from a mapping (Hydra ``manoeuvre`` group)."""
        d = dict(cfg)
        schedule = tuple(tuple(float(x) for x in seg) for seg in (d.pop("schedule", None) or ()))
        series = tuple(tuple(float(x) for x in pt) for pt in (d.pop("series", None) or ()))
        series_file = d.pop("series_file", None)
        if series_file:
            series = _read_series(series_file)
        allowed = {f for f in cls.__dataclass_fields__}
        unknown = set(d) - allowed
        if unknown:
            raise ConfigError(f"manoeuvre: unknown option(s) {sorted(unknown)}")
        return cls(schedule=schedule, series=series, **d)


def _read_series(path) -> tuple:
    """(t, delta_deg) pairs from a CSV with columns t [s] and delta [deg]."""
    table = read_table(path)
    for col in ("t", "delta"):
        if col not in table:
            raise DataError(str(path), f"a rudder series needs columns 't' [s] and 'delta' [deg]", col)
    t = table["t"].to_numpy(float)
    delta = table["delta"].to_numpy(float)
    bad = np.flatnonzero(~np.isfinite(t) | ~np.isfinite(delta))
    if len(bad):
        raise DataError(str(path), "value is not a finite number", None, int(bad[0]))
    back = np.flatnonzero(np.diff(t) <= 0)
    if len(back):
        raise DataError(str(path), "time must increase strictly", "t", int(back[0] + 1))
    return tuple(zip(t.tolist(), delta.tolist()))


def zigzag(amplitude: float, heading: float | None = None, duration: float = 600.0,
           dt: float = 0.1) -> Manoeuvre:
    """Zig-zag ``amplitude/heading`` [deg], named ``zigzag_<a>_<h>``."""
    heading = amplitude if heading is None else heading
    return Manoeuvre(f"zigzag_{amplitude:g}_{heading:g}", "zigzag", duration, dt,
                     amplitude=amplitude, heading=heading)


def turning(amplitude: float = 35.0, pullout: float = 540.0, duration: float = 900.0,
            dt: float = 0.1) -> Manoeuvre:
    """Turning circle with pull-out after ``pullout`` deg of heading change."""
    return Manoeuvre(f"turning_{amplitude:g}", "turning", duration, dt,
                     amplitude=amplitude, heading=pullout)


def zigzag_of_record(record) -> Manoeuvre | None:
    """The zig-zag a record shows, as the manoeuvre that steers it again.

    Read from the record alone (nothing about how it was made): the rudder
    amplitude is half the rudder's peak-to-peak angle to the degree, the
    execute heading the heading change [deg, to the degree] from the first
    sample at the rudder's first reversal, the first deflection's sign that
    of the first rudder departure beyond half the amplitude, the execute time
    the last sample before the rudder first leaves amidships (0 when it
    moves from the first sample); the duration and sampling are the record's. A closed-loop simulation of it reverses the
    rudder when the simulated heading has changed by the execute heading
    from the initial one, as an autopilot or helmsman does.

    Parameters
    ----------
    record : DataFrame
        Data contract (``t`` [s], ``psi`` [rad], ``delta`` [rad]).

    Returns
    -------
    Manoeuvre or None
        None when the rudder does not reverse at least twice between
        deflections of similar size (not a zig-zag).
    """
    t = record["t"].to_numpy(float)
    psi = record["psi"].to_numpy(float)
    delta = record["delta"].to_numpy(float)
    amplitude = float(np.round(np.rad2deg(0.5 * (delta.max() - delta.min()))))
    if amplitude < 1.0 or len(t) < 3:
        return None
    half = 0.5 * np.deg2rad(amplitude)
    side = np.where(delta > half, 1, np.where(delta < -half, -1, 0))
    deflected = np.flatnonzero(side != 0)
    if len(deflected) == 0:
        return None
    sides = side[deflected]
    reversals = deflected[1:][np.diff(sides) != 0]
    if len(reversals) < 2:
        return None
    first = int(sides[0])
    # the rudder turns back from its first deflection when the heading reaches the execute
    # heading: take the heading where the first deflection peaks (its last peak sample)
    segment = np.arange(deflected[0], reversals[0])
    deflection = first * delta[segment]
    peak = segment[np.flatnonzero(deflection >= deflection.max() - 1e-9)[-1]]
    heading = float(np.round(np.rad2deg(abs(psi[peak] - psi[0]))))
    if heading < 1.0:
        return None
    duration = float(t[-1] - t[0])
    dt = float(np.round(np.median(np.diff(t)), 9))
    # the execute time: the last sample before the rudder first leaves amidships (by 1 % of the
    # amplitude), when the record starts with it held there
    moved = np.flatnonzero(np.abs(delta - delta[0]) > 0.01 * np.deg2rad(amplitude))
    execute = float(np.round(t[moved[0] - 1] - t[0], 9)) if len(moved) and moved[0] > 1 \
        and abs(delta[0]) < 0.01 * np.deg2rad(amplitude) else 0.0
    return Manoeuvre(str(record.attrs.get("name", "zigzag")), "zigzag", duration, dt,
                     amplitude=amplitude, heading=heading, first_sign=first, execute=execute)
