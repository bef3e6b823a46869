"""Simulate a manoeuvre of a model: the pure function the rest of `studies` calls.

``simulate(model, values, vessel, manoeuvre)`` returns a record in the data
contract (t, x0, y0, psi, u, v, r, delta and the true wind when there is
some). Velocities in the record are over ground (what a GNSS/IMU measures);
with a current they differ from the velocities through the water that the
hydrodynamics see. The model is never mutated.

A run that leaves the physical range (see :mod:`studies.simulate.integrator`)
is marked diverged; scores of it use the finite :data:`DIVERGED_PENALTY`
instead of NaN.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..environment.conditions import Environment
from ..models.abkowitz import ManoeuvringModel
from ..vessels.base import Vessel
from ..vessels.kvlcc2_mmg import MMGVessel
from .integrator import rk4_simulate, rk4_simulate_many
from .manoeuvres import Manoeuvre, zigzag_of_record
from .mmg import MMGReplayPlan

__all__ = ["simulate", "simulate_many", "replay", "replay_many", "ReplayPlan", "SimulationInputs",
           "DIVERGED_PENALTY", "acceleration_forces", "replay_plan"]

#: finite fitness (thesis eq. 3.43, SI units) given to a simulation that left
#: the physical range, in place of NaN
DIVERGED_PENALTY = 1.0e6


@dataclass(frozen=True)
class SimulationInputs:
    """Everything the compiled integrator needs besides the coefficients."""

    powers: np.ndarray
    dofs: np.ndarray
    mass: np.ndarray
    length: float
    speed0: float
    x0: np.ndarray
    step: float
    cmd: np.ndarray
    mode: int
    params: np.ndarray
    env: np.ndarray
    wind: np.ndarray
    rho: float
    ext: np.ndarray
    servo: np.ndarray
    substeps: int

    def args(self):
        return (self.powers, self.dofs, self.mass, self.length, self.speed0, self.x0,
                self.step, self.cmd, self.mode, self.params, self.env, self.wind, self.rho,
                self.ext, self.servo)


def _servo(vessel: Vessel) -> np.ndarray:
    return np.array([vessel.rudder_max, vessel.rudder_rate, vessel.rudder_time_constant])


def prepare(model: ManoeuvringModel, vessel: Vessel, manoeuvre: Manoeuvre,
            environment: Environment | None = None, external: np.ndarray | None = None,
            yaw_sign: float = -1.0, initial: dict | None = None) -> SimulationInputs:
    """Pack the inputs of a simulation (see :func:`simulate`)."""
    environment = environment or Environment()
    mode, cmd, params = manoeuvre.rudder_programme(yaw_sign)
    n_steps = cmd.shape[0] - 1
    ext = np.zeros((0, 6)) if external is None else np.asarray(external, float)
    if external is not None and ext.shape[0] < n_steps:
        raise ValueError(f"external forces cover {ext.shape[0]} steps, need {n_steps}")
    x0 = _state_vector(initial, float(vessel.speed))
    wind = vessel.wind.as_array() if vessel.wind is not None else np.zeros(0)
    return SimulationInputs(model.powers_array(), model.dof_array(), vessel.mass_matrix(),
                            float(vessel.length), float(vessel.speed), x0, manoeuvre.step,
                            np.ascontiguousarray(cmd, float), mode, params, environment.as_array(),
                            wind, float(vessel.rho), np.ascontiguousarray(ext), _servo(vessel),
                            manoeuvre.substeps)


def _state_vector(initial: dict | None, speed0: float) -> np.ndarray:
    """The integrator's initial state (du, v, r, x0, y0, psi, delta) from
    ``initial`` (total ``u`` [m/s] through the water, ...; missing: straight
    at ``speed0``)."""
    x0 = np.zeros(7)
    if initial:
        x0[0] = initial.get("u", speed0) - speed0
        for key, idx in (("v", 1), ("r", 2), ("x0", 3), ("y0", 4), ("psi", 5), ("delta", 6)):
            x0[idx] = initial.get(key, 0.0)
    return x0


def _to_record(states: np.ndarray, inputs: SimulationInputs, environment: Environment) -> pd.DataFrame:
    states = states[:: inputs.substeps]
    t = np.arange(states.shape[0]) * inputs.step * inputs.substeps
    psi = states[:, 5]
    u = inputs.speed0 + states[:, 0]
    v = states[:, 1]
    if environment.current_speed:
        u = u + environment.current_speed * np.cos(environment.current_direction - psi)
        v = v + environment.current_speed * np.sin(environment.current_direction - psi)
    # one float block (the columns are stacked once, not consolidated by pandas)
    columns = ("t", "x0", "y0", "psi", "u", "v", "r", "delta")
    block = np.column_stack([t, states[:, 3], states[:, 4], psi, u, v, states[:, 2], states[:, 6]])
    record = pd.DataFrame(block, columns=list(columns), copy=False)
    if environment.wind_speed > 0:
        record["wind_speed"] = environment.wind_speed
        record["wind_direction"] = environment.wind_direction
    return record


def simulate(model: ManoeuvringModel, values: dict, vessel: Vessel, manoeuvre: Manoeuvre,
             environment: Environment | None = None, external: np.ndarray | None = None,
             initial: dict | None = None, scheme: str = "rk4") -> pd.DataFrame:
    """Simulate ``manoeuvre`` with coefficient ``values`` of ``model``.

    Parameters
    ----------
    model : ManoeuvringModel
    values : dict
        Prime coefficients ``{name: value}`` for every term of the model.
    vessel : Vessel
        Masses, speed, rudder limits and wind particulars.
    manoeuvre : Manoeuvre
    environment : Environment, optional
        Steady wind and current (default calm).
    external : ndarray (n_steps, 6) or (n_steps, 9), optional
        Prime external forces per integration step: earth-fixed bias
        ``(bx, by, bn)`` then body-fixed process noise ``(wx, wy, wn)``
        (prime at the current speed ``U``), then optionally body-fixed
        forces of given magnitude ``(fx, fy, fn)`` (prime at the approach
        speed ``U0``: a dimensional force that does not scale with the
        speed, such as a propeller's side force at constant rpm).
    initial : dict, optional
        Initial ``u`` (total), ``v``, ``r``, ``x0``, ``y0``, ``psi``,
        ``delta``; default straight at the vessel's speed.
    scheme : str
        ``rk4`` (default) or ``euler``: forward Euler steps, as the Marine
        Systems Simulator's ``zigzag.m`` takes them
        (:data:`~studies.simulate.integrator.SCHEMES`).

    Returns
    -------
    DataFrame
        The record (data contract); ``attrs["diverged_at"]`` is the time [s]
        where the simulation left the physical range (NaN rows after it), or
        absent when it stayed bounded.
    """
    environment = environment or Environment()
    inputs = prepare(model, vessel, manoeuvre, environment, external,
                     model.rudder_yaw_sign(values), initial)
    states, diverged = rk4_simulate(model.vector(values), *inputs.args(), scheme=scheme)
    record = _to_record(states, inputs, environment)
    record.attrs["name"] = manoeuvre.name
    if diverged >= 0:
        record.attrs["diverged_at"] = diverged * inputs.step
    return record


def simulate_many(model: ManoeuvringModel, vectors: np.ndarray, vessel: Vessel,
                  manoeuvre: Manoeuvre, environment: Environment | None = None,
                  external: np.ndarray | None = None, yaw_sign: float = -1.0,
                  initial: dict | None = None, scheme: str = "rk4"):
    """Simulate many coefficient vectors (rows, in model term order) in parallel.

    ``initial`` is the initial state and ``scheme`` the integration scheme
    as for :func:`simulate` (velocities through the water). Returns ``(t, states, diverged)``: sample times [s],
    states ``(n_sets, n_samples, 7)`` in the integrator's order (du, v, r,
    x0, y0, psi, delta) at the record's sampling, and per set the first
    diverged integration step (-1 when bounded).
    """
    inputs = prepare(model, vessel, manoeuvre, environment, external, yaw_sign, initial)
    states, diverged = rk4_simulate_many(np.atleast_2d(vectors), *inputs.args(), scheme=scheme)
    states = states[:, :: inputs.substeps]
    t = np.arange(states.shape[1]) * manoeuvre.dt
    return t, states, diverged


def _replay_inputs(model: ManoeuvringModel, vessel: Vessel, record: pd.DataFrame,
                   environment: Environment | None, yaw_sign: float,
                   external=None, max_step: float = 0.1, steer: bool = False) -> SimulationInputs:
    """The integrator's inputs of a replay: the measured rudder prescribed, or
    with ``steer`` a zig-zag record run by its rule (:func:`zigzag_of_record`)."""
    t = record["t"].to_numpy(float)
    dt = float(np.median(np.diff(t)))
    duration = dt * (len(t) - 1)
    zigzag = zigzag_of_record(record) if steer else None
    man = Manoeuvre(str(record.attrs.get("name", "record")), "rudder", duration, dt, max_step=max_step) \
        if zigzag is None else dataclasses.replace(zigzag, max_step=max_step)
    grid = man.step_times()
    environment = environment or Environment()
    initial = _replay_initial(record, environment, None)
    inputs = prepare(model, vessel, man, environment, _external_rows(external, len(grid)), yaw_sign, initial)
    if zigzag is not None:
        return inputs
    return SimulationInputs(**{**inputs.__dict__, "mode": 3, "cmd": _rudder_on_grid(record, grid)})


def _rudder_on_grid(record: pd.DataFrame, grid: np.ndarray) -> np.ndarray:
    """The record's rudder linearly interpolated onto the integrator's steps
    ``grid``, which count from the record's first sample."""
    t = record["t"].to_numpy(float)
    return np.ascontiguousarray(np.interp(grid, t - t[0], record["delta"].to_numpy(float)))


def _external_rows(external, n_grid: int):
    """External forces as one row per step (a constant vector repeated), or None."""
    if external is None:
        return None
    ext = np.asarray(external, float)
    return np.repeat(ext[None, :], n_grid - 1, axis=0) if ext.ndim == 1 else ext


#: the record's columns a replay starts from
_START_COLUMNS = ("u", "v", "r", "x0", "y0", "psi", "delta")


def _first_row(record: pd.DataFrame) -> dict:
    # column by column: selecting the columns as a frame copies the whole record
    return {c: float(record[c].to_numpy(float)[0]) for c in _START_COLUMNS}


def _replay_initial(record: pd.DataFrame, environment: Environment, initial: dict | None,
                    first: dict | None = None) -> dict:
    """A replay's initial state: the record's first row (over ground; ``first``
    when given, :func:`_first_row`), overridden by ``initial``, turned into
    velocities through the water in ``environment``'s current."""
    out = {**(first or _first_row(record)), **(initial or {})}
    if environment.current_speed:
        out["u"] -= environment.current_speed * np.cos(environment.current_direction - out["psi"])
        out["v"] -= environment.current_speed * np.sin(environment.current_direction - out["psi"])
    return out


def acceleration_forces(accelerations: np.ndarray, vessel: Vessel) -> np.ndarray:
    """Prime external forces (n, 9) that give the integrator exactly the SI
    accelerations ``accelerations`` (n, 3) [m/s^2, m/s^2, rad/s^2] in
    ``u_dot, v_dot, r_dot``.

    Columns 6-8 (body-fixed forces of given magnitude, prime at the approach
    speed ``U0``) hold ``M' [a_u L, a_v L, a_r L^2] / U0^2``, which the
    integrator turns back into ``a``.
    """
    acc = np.asarray(accelerations, float)
    L, U0 = float(vessel.length), float(vessel.speed)
    out = np.zeros((acc.shape[0], 9))
    out[:, 6:9] = (acc * np.array([L, L, L * L])) @ vessel.mass_matrix().T / (U0 * U0)
    return out


class ReplayPlan:
    """A record's replay prepared once (rudder on the integration grid,
    environment, external forces) for many coefficient sets and initial
    states: what :func:`replay_many` does, without preparing the record again
    on every call (an output-error fit replays the same windows hundreds of
    times). With ``steer`` a zig-zag record is replayed as it was run (the
    rudder reversed when the replay's heading reaches the test's angle:
    :func:`zigzag_of_record`; ``steered`` says whether it is).
    """

    def __init__(self, model: ManoeuvringModel, vessel: Vessel, record: pd.DataFrame,
                 environment: Environment | None = None, external=None, max_step: float = 0.1,
                 steer: bool = False):
        self.environment = environment or record_environment(record)
        self.record = record
        self.vessel = vessel
        self.inputs = _replay_inputs(model, vessel, record, self.environment, -1.0, external, max_step, steer)
        self.steered = int(self.inputs.mode) == 1

    def variant(self, record: pd.DataFrame | None = None, environment: Environment | None = None,
                external=None) -> "ReplayPlan":
        """The same replay with another rudder (``record``: the same time axis,
        its ``delta`` and first row used), ``environment`` or constant or
        per-step ``external`` forces (None: no external forces), without
        preparing the record again: what a fit of a cause's parameters needs
        at every trial."""
        new = object.__new__(ReplayPlan)
        new.vessel = self.vessel
        new.steered = self.steered and record is None
        new.record = self.record if record is None else record
        if record is None:
            new._first = self._first_values()
        new.environment = self.environment if environment is None else environment
        inputs = self.inputs
        n_grid = inputs.cmd.shape[0]
        grid = np.arange(n_grid) * inputs.step
        ext = _external_rows(external, n_grid)
        changes = {"env": new.environment.as_array(),
                   "ext": np.zeros((0, 6)) if ext is None else np.ascontiguousarray(ext)}
        if record is not None:
            changes["cmd"] = _rudder_on_grid(record, grid)
            changes["mode"] = 3
        new.inputs = SimulationInputs(**{**inputs.__dict__, **changes})
        return new

    def initial_state(self, initial: dict | None = None) -> np.ndarray:
        """The integrator's initial state (7,) of a replay from the record's
        first row overridden by ``initial`` (``u``, ``v`` over ground as
        recorded, ``r``, ``x0``, ``y0``, ``psi``, ``delta``): what
        :meth:`run_states` takes per set."""
        return _state_vector(_replay_initial(self.record, self.environment, initial, self._first_values()),
                             self.inputs.speed0)

    def _first_values(self) -> dict:
        if not hasattr(self, "_first"):
            self._first = _first_row(self.record)
        return self._first

    def run_states(self, vectors: np.ndarray, states: np.ndarray):
        """Many coefficient vectors, each from its own initial state (rows of
        ``states``, :meth:`initial_state`); ``(states, diverged)`` as :meth:`run`."""
        inputs = SimulationInputs(**{**self.inputs.__dict__, "x0": np.asarray(states, float)})
        out, diverged = rk4_simulate_many(np.atleast_2d(vectors), *inputs.args())
        return out[:, :: inputs.substeps], diverged

    def external_accelerations(self, accelerations: np.ndarray) -> np.ndarray:
        """What :meth:`run_one` takes as ``external`` for SI accelerations (steps, 3)
        added to ``u_dot, v_dot, r_dot`` (:func:`acceleration_forces`)."""
        return acceleration_forces(accelerations, self.vessel)

    @property
    def steps(self) -> int:
        """Integration steps of the replay (external forces need one row per step)."""
        return int(self.inputs.cmd.shape[0] - 1)

    @property
    def step(self) -> float:
        """Integration step [s]."""
        return float(self.inputs.step)

    def run_one(self, vector: np.ndarray, external=None, initial: dict | None = None,
                external_gain: float = 0.0):
        """One coefficient vector with its own external forces (one row per
        step, 6 or 9 columns as for :func:`simulate`; those of given magnitude
        times ``1 + external_gain |r'|``) and initial state; ``(states
        (n_samples, 7), diverged_at)`` at the record's samples."""
        inputs = self.inputs
        changes = {}
        if initial:
            changes["x0"] = _state_vector(_replay_initial(self.record, self.environment, initial),
                                          inputs.speed0)
        if external is not None:
            changes["ext"] = np.ascontiguousarray(external, float)
        if changes:
            inputs = SimulationInputs(**{**inputs.__dict__, **changes})
        states, diverged = rk4_simulate(np.asarray(vector, float), *inputs.args(),
                                        ext_gain=float(external_gain))
        return states[:: inputs.substeps], int(diverged)

    def run(self, vectors: np.ndarray, initial: dict | None = None):
        """``(states, diverged)`` as :func:`replay_many` returns them."""
        inputs = self.inputs
        if initial:
            x0 = _state_vector(_replay_initial(self.record, self.environment, initial), inputs.speed0)
            inputs = SimulationInputs(**{**inputs.__dict__, "x0": x0})
        states, diverged = rk4_simulate_many(np.atleast_2d(vectors), *inputs.args())
        return states[:, :: inputs.substeps], diverged


def replay_plan(model: ManoeuvringModel, vessel, record: pd.DataFrame, modules=None, steer: bool = False):
    """A record's replay prepared for many coefficient sets, on the model's own
    simulator: :class:`~studies.simulate.mmg.MMGReplayPlan` (propeller rate
    from the record's ``n``, ``modules`` the propeller and rudder parameters)
    for a vessel with MMG particulars
    (:class:`~studies.vessels.kvlcc2_mmg.MMGVessel`), :class:`ReplayPlan`
    otherwise. Both give ``steps``, ``step``, ``steered``, ``run(vectors)``,
    ``run_one(vector, external, initial)`` and ``external_accelerations``.
    With ``steer`` a zig-zag record is run by its rule, any other record
    with its measured rudder."""
    if isinstance(vessel, MMGVessel):
        return MMGReplayPlan(model, vessel, record, modules, steer=steer)
    return ReplayPlan(model, vessel, record, steer=steer)


def record_environment(record: pd.DataFrame) -> Environment:
    """The steady wind a record carries (mean of its wind columns), else calm."""
    if "wind_speed" in record and "wind_direction" in record:
        speed = float(record["wind_speed"].mean())
        direction = float(np.angle(np.mean(np.exp(1j * record["wind_direction"].to_numpy(float)))))
        return Environment(speed, direction)
    return Environment()


def replay(model: ManoeuvringModel, values: dict, vessel: Vessel, record: pd.DataFrame,
           environment: Environment | None = None, external=None) -> pd.DataFrame:
    """Simulate a record's own rudder from its own initial state.

    The measured rudder angle is prescribed (no servo) and held linear
    between samples; the integration step is the record's sampling interval
    split so it is at most 0.1 s. The environment defaults to the wind the
    record carries. This is how a model is validated against a measured
    manoeuvre, and how trajectory objectives compare coefficient sets.
    ``external`` adds prime forces: a 6- or 9-vector held constant
    (earth-fixed bias bx, by, bn and body-fixed wx, wy, wn at the current
    speed, then body-fixed fx, fy, fn at the approach speed; see
    :func:`simulate`) or one row per step.
    """
    environment = environment or record_environment(record)
    inputs = _replay_inputs(model, vessel, record, environment, model.rudder_yaw_sign(values),
                            external)
    states, diverged = rk4_simulate(model.vector(values), *inputs.args())
    out = _to_record(states, inputs, environment)
    out["t"] = out["t"] + float(record["t"].iloc[0])
    out.attrs["name"] = record.attrs.get("name", "record")
    if diverged >= 0:
        out.attrs["diverged_at"] = diverged * inputs.step
    return out


def replay_many(model: ManoeuvringModel, vectors: np.ndarray, vessel: Vessel,
                record: pd.DataFrame, environment: Environment | None = None, external=None,
                initial: dict | None = None):
    """:func:`replay` for many coefficient vectors (rows, model term order), in parallel.

    ``initial`` overrides the record's first-row states (``{"u": ..., "v": ...}``,
    over ground as recorded, m/s and rad/s).
    Returns ``(states, diverged)``: states ``(n_sets, n_samples, 7)`` at the
    record's samples in the integrator's order (du, v, r, x0, y0, psi,
    delta; velocities through the water), and the first diverged step per
    set (-1 when bounded).
    """
    return ReplayPlan(model, vessel, record, environment, external).run(vectors, initial)
