"""Every option of every problem, strategy and the planar geometry file is checked when
the object is built: a bad value or an unknown name is a ValidationError that names the
owner, the rule and the value, before any evaluation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from synthetic_problem import SyntheticIdentification

from suspenv import list_problems, make_problem
from suspenv.core.errors import ValidationError
from suspenv.core.options import check_keywords, choice, flag, integer, number, numbers, texts
from suspenv.models.planar import geometry_from_dict, load_geometry
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.problems.views import ObjectiveSubset
from suspenv.registry import list_strategies, make_strategy, problem_class, strategy_class

PROBLEMS = (
    "Sphere",
    "ZDT1",
    "CarSideImpact",
    "KCIdentification",
    "MinibusRideHandling",
    "PlanarLinkage",
)
STRATEGIES = (
    "cmaes",
    "nsga2",
    "pymoo_nsga2",
    "random",
    "lhs",
    "de",
    "nevergrad",
    "optuna_tpe",
    "optuna_cmaes",
    "optuna_nsga3",
    "optuna_gp",
)


def raises(call, *fragments: str) -> str:
    """Run ``call``; it must raise ValidationError whose message holds every fragment."""
    with pytest.raises(ValidationError) as err:
        call()
    text = str(err.value)
    for fragment in fragments:
        assert fragment in text, f"{fragment!r} not in {text!r}"
    return text


# ------------------------------------------------------------------ the helper
def test_integer_refuses_fractions_bools_and_non_finite_values():
    assert integer("o", "n", 3) == 3
    assert integer("o", "n", np.int64(3)) == 3
    assert integer("o", "n", 3.0) == 3 and isinstance(integer("o", "n", 3.0), int)
    raises(lambda: integer("o", "n", 2.5), "o: `n` must be an integer", "n=2.5")
    raises(lambda: integer("o", "n", True), "must be an integer", "n=True (bool)")
    raises(lambda: integer("o", "n", math.nan), "must be an integer", "n=nan")
    raises(lambda: integer("o", "n", "3"), "must be an integer", "n='3' (str)")
    raises(lambda: integer("o", "n", 1, lo=2), "o: `n >= 2` must hold, but got n=1")


def test_number_refuses_non_finite_values_and_names_the_range():
    assert number("o", "x", np.float64(0.5), lo=0, hi=1) == 0.5
    raises(
        lambda: number("o", "x", 1.5, lo=0, hi=1, lo_open=True),
        "o: `0 < x <= 1` must hold, but got x=1.5",
    )
    raises(lambda: number("o", "x", math.inf, lo=0, lo_open=True), "finite", "`x > 0`", "x=inf")
    raises(lambda: number("o", "x", math.nan), "`x` must be a finite number, but got x=nan")
    raises(lambda: number("o", "x", False), "must be a number", "(bool)")
    raises(lambda: number("o", "x", "1.5"), "must be a number", "(str)")
    raises(lambda: number("o", "x", 10**400), "finite")


def test_choice_keywords_and_lists_suggest_the_nearest_name():
    assert choice("o", "c", "re41", ("CRE31", "RE41"), ignore_case=True) == "RE41"
    raises(lambda: choice("o", "c", "lloid", ("random-cd", "lloyd")), "did you mean 'lloyd'?")
    text = raises(
        lambda: check_keywords("thing", {"alpah": 1, "zzz": 2}, ["alpha", "beta"]),
        "unknown options 'alpah' (did you mean 'alpha'?), 'zzz'",
        "valid options: alpha, beta",
    )
    assert "zzz' (did" not in text
    assert numbers("o", "w", (1, 2.5)) == [1.0, 2.5]
    raises(lambda: numbers("o", "w", [1.0, math.nan]), "`w[1]` must be a finite number")
    raises(lambda: numbers("o", "w", [1.0], length=2), "`len(w) == 2` must hold")
    raises(lambda: texts("o", "names", "noise"), "`names` must be a list of strings")


# ------------------------------------------------------- unknown option names
@pytest.mark.parametrize(
    ("name", "typo", "meant"),
    [
        ("Sphere", "dimm", "dim"),
        ("ZDT1", "Dim", "dim"),
        ("CarSideImpact", "varient", "variant"),
        ("KCIdentification", "truth_sed", "truth_seed"),
        ("MinibusRideHandling", "road_clas", "road_class"),
        ("PlanarLinkage", "target_camber_gian", "target_camber_gain"),
    ],
)
def test_unknown_problem_options_suggest_the_nearest(name, typo, meant):
    raises(
        lambda: make_problem(name, **{typo: 1}),
        f"problem {name!r}: unknown option {typo!r} (did you mean {meant!r}?)",
        "valid options:",
        meant,
    )


def test_every_built_in_problem_and_strategy_is_covered():
    # problems and strategies of suspenv itself (tests may register their own)
    problems = {n for n in list_problems() if problem_class(n).__module__.startswith("suspenv.")}
    assert problems == set(PROBLEMS)
    names = {n for n in list_strategies() if strategy_class(n).__module__.startswith("suspenv.")}
    assert names == set(STRATEGIES)


@pytest.mark.parametrize(
    ("name", "typo", "meant"),
    [
        ("cmaes", "sigma", "sigma0"),
        ("nsga2", "populaton_size", "population_size"),
        ("pymoo_nsga2", "mutaton_eta", "mutation_eta"),
        ("random", "batchsize", "batch_size"),
        ("lhs", "n_sample", "n_samples"),
    ],
)
def test_unknown_strategy_options_suggest_the_nearest(name, typo, meant):
    problem = make_problem("Sphere", dim=2)
    raises(
        lambda: make_strategy(name, problem, **{typo: 1}),
        f"strategy {name!r}: unknown option {typo!r} (did you mean {meant!r}?)",
        "valid options:",
    )


# ------------------------------------------------------------ problem values
@pytest.mark.parametrize(
    ("name", "options", "fragments"),
    [
        ("Sphere", {"dim": 2.5}, ("Sphere: `dim` must be an integer", "dim=2.5")),
        ("Sphere", {"dim": True}, ("`dim` must be an integer", "dim=True")),
        ("Sphere", {"dim": 0}, ("Sphere: `dim >= 1` must hold, but got dim=0",)),
        ("Sphere", {"delay_s": math.nan}, ("`delay_s` must be a finite number", "nan")),
        ("ZDT1", {"dim": 1}, ("ZDT1: `dim >= 2` must hold, but got dim=1",)),
        ("CarSideImpact", {"variant": "CRE3"}, ("`variant` must be one of", "'CRE31'?")),
        ("CarSideImpact", {"constraint_scale": 1}, ("`constraint_scale` must be one of",)),
        (
            "KCIdentification",
            {"amplitude_mm": math.inf},
            ("KCIdentification: `amplitude_mm` must be a finite number", "amplitude_mm=inf"),
        ),
        ("KCIdentification", {"amplitude_mm": 90}, ("`0 < amplitude_mm <= 80`", "=90")),
        ("KCIdentification", {"steps": 9}, ("`steps` must be even and >= 8", "steps=9")),
        ("KCIdentification", {"steps": 30.5}, ("`steps` must be an integer", "steps=30.5")),
        ("KCIdentification", {"truth_seed": -1}, ("`truth_seed >= 0`", "truth_seed=-1")),
        ("KCIdentification", {"concealed": "noise"}, ("`concealed` must be a list",)),
        ("KCIdentification", {"concealed": ["nosie"]}, ("did you mean 'noise'?",)),
        (
            "KCIdentification",
            {"model_effects": [{"kind": "coulomb_friction", "locaton": "strut"}]},
            ("model_effects[0]: unknown key 'locaton' (did you mean 'location'?)",),
        ),
        (
            "KCIdentification",
            {
                "model_effects": [
                    {"kind": "coulomb_friction", "location": "strut", "params": {"f_c": math.nan}}
                ]
            },
            ("`params.f_c` must be a finite number", "nan"),
        ),
        (
            "MinibusRideHandling",
            {"road_class": "Z"},
            ("MinibusRideHandling: `road_class` must be one of ['A',", "but got 'Z'"),
        ),
        ("MinibusRideHandling", {"road_class": True}, ("`road_class` must be one of",)),
        ("MinibusRideHandling", {"road_class": -1.0}, ("`0 < road_class <= 0.524288`",)),
        (
            "MinibusRideHandling",
            {"speed_kmh": math.inf},
            ("`speed_kmh` must be a finite number with `speed_kmh > 0`", "speed_kmh=inf"),
        ),
        ("MinibusRideHandling", {"speed_kmh": 0}, ("`speed_kmh > 0` must hold", "=0")),
        ("MinibusRideHandling", {"load_weight": math.nan}, ("load_weight", "nan")),
        ("MinibusRideHandling", {"ride_duration_s": 0.001}, ("`ride_duration_s >= 2`",)),
        ("MinibusRideHandling", {"slalom_dt": 0.2}, ("`0 < slalom_dt <= 0.05`", "0.2")),
        ("MinibusRideHandling", {"n_cones": 6.5}, ("`n_cones` must be an integer", "6.5")),
        ("MinibusRideHandling", {"road_seed": -2}, ("`road_seed >= 0`",)),
        (
            "PlanarLinkage",
            {"target_camber_gain": math.nan},
            ("PlanarLinkage: `target_camber_gain` must be a finite number", "=nan"),
        ),
        ("PlanarLinkage", {"target_camber_gain": "-20"}, ("must be a number", "(str)")),
        ("PlanarLinkage", {"n_travel": 61.5}, ("`n_travel` must be an integer", "61.5")),
        ("PlanarLinkage", {"span": math.inf}, ("`span` must be a finite number", "inf")),
        ("PlanarLinkage", {"solver": "analytc"}, ("did you mean 'analytic'?",)),
        ("PlanarLinkage", {"variables": "upper_inner.y"}, ("`variables` must be a list",)),
        ("PlanarLinkage", {"variables": []}, ("`variables` must not be empty",)),
        ("PlanarLinkage", {"variables": ["uper_inner.y"]}, ("did you mean 'upper_inner.y'?",)),
        (
            "PlanarLinkage",
            {"roll_centre_range": [0.0, math.nan]},
            ("`roll_centre_range[1]` must be a finite number",),
        ),
        ("PlanarLinkage", {"roll_centre_range": [1.0]}, ("`len(roll_centre_range) == 2`",)),
        (
            "PlanarLinkage",
            {"target": "double_wishbone_target", "target_camber_gain": -20.0},
            ("give `target` (curves) or `target_camber_gain`", "not both"),
        ),
    ],
)
def test_bad_problem_options_name_the_rule_and_the_value(name, options, fragments):
    raises(lambda: make_problem(name, **options), *fragments)


def test_minibus_bad_road_fails_at_construction_not_in_every_evaluation():
    # the issue: road_class "Z" and speed_kmh inf made every evaluation fail, exit 0
    for options in ({"road_class": "Z"}, {"speed_kmh": math.inf}):
        raises(lambda options=options: MinibusRideHandling(**options), "MinibusRideHandling:")
    p = MinibusRideHandling(road_class="b", road_seed=3.0)
    assert p.config()["road_class"] == "B" and p.config()["road_seed"] == 3
    assert MinibusRideHandling(road_class=1e-4).config()["road_class"] == 1e-4


def test_valid_options_are_kept_as_plain_values():
    p = make_problem("Sphere", dim=3.0, delay_s=np.float64(0.0))
    assert p.config() == {"dim": 3, "delay_s": 0.0} and isinstance(p.dim, int)
    q = make_problem("PlanarLinkage", target_camber_gain=np.float64(-20.0), n_travel=np.int64(21))
    assert q.config()["target_camber_gain"] == -20.0 and q.config()["n_travel"] == 21
    assert type(q.config()["target_camber_gain"]) is float


def test_views_and_the_synthetic_problem_check_their_options():
    base = make_problem("ZDT1", dim=3)
    raises(lambda: ObjectiveSubset(base, [2]), "`0 <= keep[0] <= 1` must hold", "keep[0]=2")
    raises(lambda: ObjectiveSubset(base, [0.5]), "`keep[0]` must be an integer")
    raises(lambda: ObjectiveSubset(base, [0, 0]), "distinct")
    raises(lambda: SyntheticIdentification(hysteresis=-0.1), "`hysteresis >= 0`")


# ----------------------------------------------------------- strategy values
@pytest.mark.parametrize(
    ("name", "options", "fragments"),
    [
        ("cmaes", {"popsize": 2.5}, ("cmaes: `popsize` must be an integer", "popsize=2.5")),
        ("cmaes", {"popsize": 1}, ("cmaes: `popsize >= 2` must hold, but got popsize=1",)),
        ("cmaes", {"sigma0": 1.5}, ("cmaes: `0 < sigma0 <= 1` must hold, but got sigma0=1.5",)),
        ("cmaes", {"sigma0": math.nan}, ("`sigma0` must be a finite number", "sigma0=nan")),
        ("cmaes", {"x0": [0.5]}, ("`len(x0) == 2` must hold",)),
        ("cmaes", {"x0": [0.5, 1.2]}, ("`0 <= x0[1] <= 1` must hold, but got x0[1]=1.2",)),
        ("cmaes", {"restarts": -1}, ("`restarts >= 0`",)),
        ("cmaes", {"incpopsize": 0.5}, ("`incpopsize >= 1`", "incpopsize=0.5")),
        ("cmaes", {"tolfun": -1e-3}, ("`tolfun >= 0`",)),
        ("cmaes", {"tolx": math.inf}, ("`tolx` must be a finite number",)),
        ("cmaes", {"max_failed_generations": 0}, ("`max_failed_generations >= 1`",)),
        ("cmaes", {"scalarizer": "rank-sum"}, ("`scalarizer` must be one of", "'rank_sum'?")),
        ("cmaes", {"weights": [1.0, math.inf]}, ("`weights[1]` must be a finite number",)),
        ("cmaes", {"weights": [1.0]}, ("`len(weights) == 2` must hold",)),
        (
            "cmaes",
            {"weights": [1.0, 1.0], "scalarizer": "rank_sum"},
            ("`weights` apply only with scalarizer='weighted_sum'",),
        ),
        ("nsga2", {"population_size": 1}, ("nsga2: `population_size >= 2`",)),
        ("nsga2", {"crossover_prob": 1.5}, ("`0 <= crossover_prob <= 1`", "=1.5")),
        ("nsga2", {"mutation_prob": math.nan}, ("`mutation_prob` must be a finite number",)),
        ("nsga2", {"swapping_prob": -0.1}, ("`0 <= swapping_prob <= 1`",)),
        ("nsga2", {"storage": 5}, ("`storage` must be a string",)),
        ("nsga2", {"study_name": ""}, ("`study_name` must not be empty",)),
        ("pymoo_nsga2", {"population_size": True}, ("`population_size` must be an integer",)),
        ("pymoo_nsga2", {"crossover_eta": 0}, ("`crossover_eta > 0` must hold",)),
        ("pymoo_nsga2", {"mutation_eta": math.inf}, ("`mutation_eta` must be a finite",)),
        ("random", {"batch_size": 0}, ("random: `batch_size >= 1`",)),
        ("random", {"batch_size": 2.5}, ("`batch_size` must be an integer", "2.5")),
        ("lhs", {"n_samples": 0}, ("lhs: `n_samples >= 1`",)),
        ("lhs", {"optimization": "loyd"}, ("`optimization` must be one of", "'lloyd'?")),
    ],
)
def test_bad_strategy_options_name_the_rule_and_the_value(name, options, fragments):
    problem = make_problem("ZDT1", dim=2)
    raises(lambda: make_strategy(name, problem, **options), *fragments)


@pytest.mark.parametrize("name", STRATEGIES)
def test_the_seed_is_a_non_negative_integer(name):
    problem = make_problem("Sphere", dim=2)
    raises(lambda: make_strategy(name, problem, seed=-1), f"{name}: `seed >= 0`")
    raises(lambda: make_strategy(name, problem, seed=1.5), "`seed` must be an integer")


# ------------------------------------------------------- planar geometry files
def write(tmp_path, text: str):
    path = tmp_path / "linkage.toml"
    path.write_text(text)
    return path


def geometry_text(**replace: str) -> str:
    from suspenv.models.planar import geometry_to_toml

    text = geometry_to_toml(load_geometry("mcpherson"))
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    return text


def test_planar_file_misspelt_table_or_key_is_an_error_with_a_suggestion(tmp_path):
    path = write(tmp_path, geometry_text(**{"[wheel]": "[wheels]"}))
    raises(lambda: load_geometry(path), "unknown key 'wheels' (did you mean 'wheel'?)", "linkage")
    path = write(tmp_path, geometry_text(**{"rate =": "rat ="}))
    raises(lambda: load_geometry(path), "[spring]: unknown key 'rat' (did you mean 'rate'?)")
    path = write(tmp_path, geometry_text(**{"strut_top =": "strut_tp ="}))
    raises(lambda: load_geometry(path), "unknown point 'strut_tp' (did you mean 'strut_top'?)")
    raises(lambda: make_problem("PlanarLinkage", geometry=str(path)), "did you mean 'strut_top'?")


def test_planar_file_values_are_checked(tmp_path):
    path = write(tmp_path, geometry_text(**{"rate = ": "rate = nan #"}))
    raises(lambda: load_geometry(path), "`spring.rate` must be a finite number", "nan")
    path = write(tmp_path, geometry_text(**{"static_camber = ": "static_camber = 50 #"}))
    raises(lambda: load_geometry(path), "`-45 < wheel.static_camber < 45` must hold", "=50")
    path = write(tmp_path, geometry_text(**{"damping = ": "damping = -1 #"}))
    raises(lambda: load_geometry(path), "`spring.damping >= 0` must hold")
    path = write(tmp_path, geometry_text(**{'kind = "': 'kind = "mcpherson_strut" #'}))
    raises(lambda: load_geometry(path), "`kind` must be one of", "did you mean 'mcpherson'?")
    path = write(tmp_path, geometry_text() + "\nthis is not toml\n")
    raises(lambda: load_geometry(path), "is not valid TOML")


def test_planar_dict_points_must_be_finite_pairs():
    d = load_geometry("mcpherson").to_dict()
    d["points"]["strut_top"] = [600.0, 680.0, 1.0]
    raises(lambda: geometry_from_dict(d), "`len(points.strut_top) == 2` must hold")
    d["points"]["strut_top"] = [600.0, math.inf]
    raises(lambda: geometry_from_dict(d), "`points.strut_top[1]` must be a finite number")


def test_a_flag_is_a_bool_and_nothing_that_merely_casts_to_one():
    assert flag("o", "x", True) is True and flag("o", "x", np.bool_(False)) is False
    assert flag("o", "x", None, allow_none=True) is None
    for value in (1, 0, "true", None, np.array([True])):
        with pytest.raises(ValidationError, match=r"o: `x` must be True or False, but got x="):
            flag("o", "x", value)
    with pytest.raises(ValidationError, match=r"must be True, False or None, but got x=1 \(int"):
        flag("o", "x", 1, allow_none=True)
    # the config's and the problems' own flags go through it
    with pytest.raises(ValidationError, match="`working_space` must be True or False"):
        MinibusRideHandling(working_space=1)
