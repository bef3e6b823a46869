"""The typed configuration (:mod:`studies.config`) against the packaged YAML files.

Every option of every config group and every experiment preset is composed
with Hydra's compose API for ``studies run`` (config.yaml), ``studies
discover`` (discover.yaml) and ``studies report`` (report.yaml) and turned
into its dataclasses with ``OmegaConf.to_object``; impossible values are
refused with the key named. In process, no subprocesses.
"""

import re
from dataclasses import MISSING, fields, is_dataclass
from pathlib import Path

import pytest
from hydra import compose
from hydra.core.config_store import ConfigStore
from hydra.core.override_parser.overrides_parser import OverridesParser
from omegaconf import OmegaConf, open_dict

from studies import config as C
from studies.errors import ConfigError

CONF = C.CONF_DIR

#: the dataclass each option of a group becomes
METHODS = {"ls": C.MethodConfig, "nls": C.MethodConfig, "fls": C.MethodConfig,
           "nls_svm": C.MethodConfig, "svm": C.SvmMethod, "ls_ga": C.GaMethod,
           "svm_ga": C.GaMethod, "bayes": C.BayesMethod, "sindy": C.SindyMethod}
MODELS = {"abkowitz": C.ModelConfig, "symmetric": C.ModelConfig,
          "simplified": C.SimplifiedModelConfig, "simplified_li2023": C.ModelConfig,
          "roll": C.RollModelConfig, "mmg": C.MMGModelConfig}
GROUPS = {"vessel": None, "model": MODELS, "method": METHODS, "manoeuvre": None}


def _options(group: str) -> list:
    return sorted(p.stem for p in (CONF / group).glob("*.yaml"))


PRESETS = _options("experiment")
CASES = [(group, option) for group in GROUPS for option in _options(group)]


def _typed(name: str, overrides=()):
    return OmegaConf.to_object(compose(name, overrides=list(overrides)))


def _check_group(cfg, group: str, option: str) -> None:
    node = getattr(cfg, group)
    expected = (GROUPS[group] or {}).get(option) or {
        "vessel": C.VesselConfig, "manoeuvre": C.ManoeuvreConfig}.get(group)
    assert type(node) is expected, (group, option, type(node))
    assert node.name == option


def test_every_group_option_has_its_schema():
    """Every option of the four groups is listed here with its dataclass."""
    assert set(METHODS) == set(_options("method"))
    assert set(MODELS) == set(_options("model"))


@pytest.mark.parametrize("command,config_type", [("config", C.RunConfig),
                                                 ("discover", C.DiscoverConfig)])
@pytest.mark.parametrize("group,option", CASES, ids=[f"{g}={o}" for g, o in CASES])
def test_every_option_composes_into_its_dataclass(hydra, command, config_type, group, option):
    cfg = _typed(command, [f"{group}={option}"])
    assert type(cfg) is config_type
    _check_group(cfg, group, option)
    assert isinstance(cfg.vessel, C.VesselConfig) and isinstance(cfg.manoeuvre, C.ManoeuvreConfig)
    assert isinstance(cfg.model, C.ModelConfig) and isinstance(cfg.method, C.MethodConfig)
    for item in fields(config_type):
        if is_dataclass(item.type):
            assert isinstance(getattr(cfg, item.name), item.type), item.name


@pytest.mark.parametrize("command,config_type", [("config", C.RunConfig),
                                                 ("discover", C.DiscoverConfig)])
@pytest.mark.parametrize("preset", PRESETS)
def test_every_preset_composes(hydra, command, config_type, preset):
    full = compose(command, overrides=[f"experiment={preset}"], return_hydra_config=True)
    params = OmegaConf.select(full, "hydra.sweeper.params") or {}      # a single-run preset has none
    with open_dict(full):
        del full["hydra"]
    cfg = OmegaConf.to_object(full)
    assert type(cfg) is config_type
    assert cfg.preset == preset
    expected = "discover" if command == "discover" else preset
    assert cfg.tracking.experiment == expected
    # the sweep a preset declares composes too (first value of each swept key)
    sweeps = OverridesParser.create().parse_overrides([f"{k}={v}" for k, v in params.items()])
    first = [f"{s.get_key_element()}={next(iter(s.sweep_string_iterator()))}" for s in sweeps]
    assert type(_typed(command, [f"experiment={preset}", *first])) is config_type


def test_report_config(hydra):
    cfg = _typed("report")
    assert type(cfg) is C.ReportCommandConfig
    assert cfg == C.ReportCommandConfig()
    assert _typed("report", ["report.experiment=thesis_noise"]).report.experiment == "thesis_noise"


@pytest.mark.slow
def test_defaults_are_the_yaml_values(hydra):
    """The dataclasses' defaults are the values of the YAML files, key for key."""
    run = _typed("config")
    for item in fields(C.RunConfig):
        if item.name not in GROUPS:
            default = item.default if item.default is not MISSING else item.default_factory()
            assert getattr(run, item.name) == default, item.name
    discover = _typed("discover")
    assert discover.discover == C.DiscoverOptions()
    assert discover.simulation == C.SimulationInput()
    assert discover.tracking == C.Tracking(experiment="discover")
    schemas = {"svm": C.SvmMethod(name="svm", seed=0),
               "ls_ga": C.GaMethod(name="ls_ga", base="ls", seed=0),
               "svm_ga": C.GaMethod(name="svm_ga", base="svm", seed=0),
               "bayes": C.BayesMethod(name="bayes", seed=0),
               "sindy": C.SindyMethod(name="sindy")}
    for option, expected in schemas.items():
        assert _typed("config", [f"method={option}"]).method == expected, option
    assert _typed("config", ["model=roll"]).model == C.RollModelConfig(name="roll")


def test_interpolations_follow_their_keys(hydra):
    cfg = _typed("config", ["method=bayes", "seed=7"])
    assert cfg.method.seed == 7
    for option in ("svm", "ls_ga", "svm_ga"):
        assert _typed("config", [f"method={option}", "seed=3"]).method.seed == 3
    cfg = _typed("config", ["model=simplified", "simplify.output=models/other.json"])
    assert cfg.model.definition == "models/other.json"


def test_excitation_preset_keeps_its_method_and_manoeuvre_settings(hydra):
    cfg = _typed("config", ["experiment=excitation", "manoeuvre=circle"])
    assert type(cfg.method) is C.MethodConfig and cfg.method.name == "ls"
    assert cfg.manoeuvre.duration == 600.0 and cfg.manoeuvre.dt == 1.0
    assert cfg.manoeuvre.schedule == [[0.0, 600.0, 20.0]]
    assert cfg.validate.manoeuvres == ["zigzag_20_20", "zigzag_like", "random", "circle"]


@pytest.mark.slow
def test_the_thesis_conventions_make_its_data_as_mss_does(hydra):
    """conventions=zhu2021: the thesis' wind and GA fitness, and its records as MSS
    zigzag.m makes them (Euler steps, the rudder laid at 9.5 s, starboard first)
    differenced forward (eq. 3.9)."""
    for preset in ("thesis_wind_speed", "thesis_noise", "thesis_direction"):
        # a preset named after the thesis uses its set-up by default
        for cfg in (_typed("config", [f"experiment={preset}"]),
                    _typed("config", [f"experiment={preset}", "conventions=zhu2021"])):
            assert (cfg.wind.convention, cfg.objective.simulation) == ("zhu2021", "closed_loop")
            assert (cfg.data.scheme, cfg.data.derivative, cfg.manoeuvre.first_sign, cfg.manoeuvre.execute) == \
                ("euler", "forward", -1, 9.5)
        # the project's own set-up is the named variant
        project = _typed("config", [f"experiment={preset}", "conventions=project"])
        assert (project.data.scheme, project.manoeuvre.first_sign, project.manoeuvre.execute) == ("rk4", None, None)
        assert project.objective.simulation != "closed_loop"
    assert _typed("config", []).data.scheme == "rk4"


def test_roll_model_says_which_study_runs_it(hydra):
    assert _typed("config", ["model=roll"]).model.study == "roll_decay"
    for option in ("abkowitz", "symmetric", "simplified"):
        assert _typed("config", [f"model={option}"]).model.study == "manoeuvring"


BAD = [
    ("config", ["wind.speed=-3"], "wind.speed must be >= 0.0, got -3.0"),
    ("config", ["seed=-1"], "seed must be non-negative, got -1"),
    ("config", ["disturbance.level=5"], "disturbance.level must be one of NL0-NL3"),
    ("config", ["disturbance.scaling=per_minute"],
     "disturbance.scaling must be one of record, per_second, got 'per_minute'"),
    ("config", ["validate.manoeuvres=[zigzag_99]"],
     "validate.manoeuvres: unknown manoeuvre 'zigzag_99'; known: "),
    ("config", ["method=bayes", "method.n_samples=0"], "method.n_samples must be an integer >= 1, got 0"),
    ("discover", ["discover.method=search"], "discover.method=search: the rule-based search was retired"),
    ("config", ["noise.measurement=5"], "noise.measurement must be <= 1.0"),
    ("config", ["validate.duration=-1"], "validate.duration must be positive"),
    ("config", ["data.derivative=spline"], "data.derivative must be one of"),
    ("config", ["data.scheme=midpoint"], "data.scheme must be one of rk4, euler, got 'midpoint'"),
    ("config", ["manoeuvre.first_sign=2"], "manoeuvre.first_sign must be 1 or -1, got 2"),
    ("config", ["manoeuvre.execute=5000"], "manoeuvre.execute must be in [0, duration), got 5000.0"),
    ("config", ["kalman.iterations=-1"], "kalman.iterations must be >= 0"),
    ("config", ["model=roll", "model.terms=[b1,b7]"], "model.terms: unknown roll terms ['b7']"),
    ("discover", ["discover.holdout=0.9"], "discover.holdout must be in [0.05, 0.8], got 0.9"),
    ("config", ["model=mmg", "model.hull=round"], "model.hull must be one of standard, thrust, reduced, crossflow, auto"),
    ("config", ["model=mmg", "model.hull=reduced", "model.rudder_lift=fit"],
     "model.hull=reduced: the reduced family carries the rudder in its hull terms"),
]


@pytest.mark.parametrize("command,overrides,text", BAD, ids=[" ".join(o) for _, o, _ in BAD])
def test_impossible_values_are_refused_with_the_key(hydra, command, overrides, text):
    cfg = compose(command, overrides=overrides)        # the types are right: composes
    with pytest.raises(ConfigError) as info:
        OmegaConf.to_object(cfg)
    assert text in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("override,text", [
    ("wind.speed=fast", "wind.speed must be a number, got 'fast'"),
    ("resume=perhaps", "resume must be true or false, got 'perhaps'"),
    ("seed=1.5", "seed must be an integer, got 1.5"),
    ("wind=3", "wind: is a group of settings (speed, direction, convention)"),
])
def test_wrong_types_are_refused_while_composing(hydra, override, text):
    with pytest.raises(Exception) as info:
        compose("config", overrides=[override])
    explained = C.explain_validation_error(info.value)
    assert isinstance(explained, ConfigError) and text in str(explained)


def test_unknown_key_is_refused_while_composing(hydra):
    with pytest.raises(Exception) as info:
        compose("config", overrides=["wind.spead=3"])
    assert "wind.spead" in str(info.value) + str(info.value.__cause__)
    assert C.explain_validation_error(info.value) is None


def test_dataclasses_check_their_values_when_built_directly():
    with pytest.raises(ConfigError, match="wind.speed must be >= 0.0, got -3.0"):
        C.Wind(speed=-3.0)
    with pytest.raises(ConfigError, match="validate.wind.speed must be <= 100.0"):
        C.ValidationWind(speed=200.0)
    assert C.Validate(manoeuvres="zigzag_10_10").manoeuvres == ["zigzag_10_10"]
    with pytest.raises(ConfigError, match="manoeuvre.duration must be positive"):
        C.ManoeuvreConfig(name="z", kind="zigzag", duration=-1.0)


def test_packaged_manoeuvres():
    names = C.known_manoeuvres()
    assert "zigzag_20_20" in names and "roll_decay" in names
    zigzag = C.manoeuvre_config("zigzag_10_10")
    assert (zigzag.kind, zigzag.amplitude, zigzag.heading, zigzag.duration) == ("zigzag", 10.0, 10.0, 600.0)
    with pytest.raises(ConfigError, match="unknown manoeuvre 'nope'; known: circle"):
        C.manoeuvre_config("nope")


def test_register_is_idempotent_and_every_yaml_names_a_stored_schema():
    C.register()
    C.register()
    store = ConfigStore.instance()
    stored = {(group, name) for group, name, _ in C.SCHEMAS}
    for group, name in stored:
        assert store.load(f"{group}/{name}.yaml" if group else f"{name}.yaml") is not None
    for path in CONF.rglob("*.yaml"):
        if path.parent.name in ("experiment", "conventions"):
            continue        # presets (# @package _global_) change values only
        defaults = [d for d in OmegaConf.load(path).get("defaults", [])]
        group = None if path.parent == CONF else path.parent.name
        named = {(group, d) for d in defaults if isinstance(d, str)}
        assert named & stored, path


def test_ga_settings_are_checked_before_any_run(hydra):
    from studies.identification.ga import BASE_METHODS

    assert set(BASE_METHODS) == set(C.GA_BASES)
    for override, message in (("method.base=bogus", "method.base must be one of ls, svm"),
                              ("method.population=1", "method.population must be >= 2"),
                              ("method.parents_mating=9", "must not exceed method.population"),
                              ("method.mutation_probability=1.5", "method.mutation_probability must be in [0, 1]"),
                              ("method.parent_selection=best", "method.parent_selection must be one of")):
        with pytest.raises(ConfigError, match=re.escape(message)):
            _typed("config", ["method=ls_ga", override])
    assert _typed("config", ["method=svm_ga"]).method.base == "svm"
