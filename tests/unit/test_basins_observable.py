"""The basins observable's spec surface: [basins] starts, seed and max_attractors, read
only with the observable, refused with the file, the key and the allowed values,
entering the fingerprint only when basins is asked for (every other spec's stays), and
counted by the size guard with its attractor slots."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from study.engine.spec_files import SpecError
from study.studies.observable_table import markdown_table
from study.studies.observables import OBSERVABLES, BasinSettings
from study.studies.spec import load_spec, parse_spec
from study.studies.variables import VARIABLES

REPO = Path(__file__).resolve().parents[2]
PATH = "own/basins.toml"

BASE = """\
[study]
name = "b"
observables = {observables}

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25

[sweep]
f = {{ start = 12.0, stop = 17.0, num = {num} }}
a = {{ values = [9.0, 10.0] }}

[solver]
coupling = "two-way"
flight = true
{solver}
{basins}"""


def text(observables='["basins"]', basins="", solver="", num=6) -> str:
    return BASE.format(observables=observables, basins=basins, solver=solver, num=num)


def test_the_defaults_and_given_settings_are_read():
    spec = parse_spec(text(), PATH)
    assert spec.basins == BasinSettings(24, 0, 8, 8)
    assert spec.canonical["basins"] == {"starts": 24, "seed": 0, "max_attractors": 8,
                                        "sweep_steps": 8}
    assert spec.observables == ("basins",)
    given = parse_spec(text(basins="[basins]\nstarts = 12\nseed = 3\nmax_attractors = 2\n"
                                   "sweep_steps = 0\n"), PATH)
    assert given.basins == BasinSettings(starts=12, seed=3, max_attractors=2, sweep_steps=0)
    assert given.dimension_sizes == {"attractor": 2}
    assert given.sha256 != spec.sha256


def test_the_fingerprint_names_basins_only_when_asked_for():
    plain = parse_spec(text(observables='["velocity"]'), PATH)
    assert plain.basins is None and "basins" not in plain.canonical
    # Spelled-out defaults are the same study.
    spelled = parse_spec(text(basins="[basins]\nstarts = 24\nseed = 0\nmax_attractors = 8\n"),
                         PATH)
    assert spelled.sha256 == parse_spec(text(), PATH).sha256


#: Fingerprints of workflow specs as study wrote them before the basins observable
#: existed (commit cbbfdd3): a spec without basins keeps its fingerprint, its cache keys
#: and so its values.
KEPT_FINGERPRINTS = {
    "regime-map-two-way": "19e543d1d4345c775b8fd18ddadb871afc660e04f8fc93791da9ffa5e5f5a946",
    "mass-ratio-limit-flight":
        "413432ff74b826d69112e4cd1b9a02debb676f5722b460f5a9644768e93919c6",
    "irregular-bouncing": "70564a03c60b6bf9e1c5cfc06e3cfaff723a273592e0d1be89f0ff5ea894c42f",
}


@pytest.mark.parametrize("name", sorted(KEPT_FINGERPRINTS))
def test_existing_workflows_keep_their_fingerprints(name):
    spec = load_spec(REPO / "workflows" / f"{name}.toml")
    assert spec.basins is None and "basins" not in spec.canonical
    assert spec.sha256 == KEPT_FINGERPRINTS[name]


REFUSALS = [
    (dict(basins="[basins]\nstart = 3\n"), ["[basins]", "unknown key 'start'",
                                            "allowed keys: max_attractors, seed, starts"]),
    (dict(basins="[basins]\nstarts = 0\n"), ["[basins] starts = 0", "allowed: >= 1"]),
    (dict(basins="[basins]\nseed = -2\n"), ["[basins] seed = -2", "allowed: >= 0"]),
    (dict(basins="[basins]\nmax_attractors = 2.5\n"),
     ["[basins] max_attractors", "expected integer"]),
    (dict(basins='[basins]\nstarts = "many"\n'), ["[basins] starts", "expected integer"]),
    (dict(observables='["velocity"]', basins="[basins]\nstarts = 4\n"),
     ['[basins] is read only by the observable "basins"',
      'allowed: add "basins" to [study] observables, or remove [basins]']),
    (dict(observables='["attractors", "basins"]'),
     ['"attractors" and "basins" both write attractor_count', "allowed: one of them"]),
    (dict(solver="continuation = true"),
     ['observable "basins" with [solver] continuation = true',
      "allowed: continuation = false"]),
    (dict(solver='method = "integrator"'),
     ['observable "basins" needs [solver] coupling = "two-way" with method = "exact"']),
]


@pytest.mark.parametrize(("changes", "words"), REFUSALS)
def test_refusals_name_the_file_the_key_and_what_is_allowed(changes, words):
    with pytest.raises(SpecError) as err:
        parse_spec(text(**changes), PATH)
    message = str(err.value)
    assert message.startswith(f"{PATH}: ")
    for fragment in words:
        assert fragment in message, (fragment, message)


def test_a_slow_sweep_is_refused():
    spec = text().replace('a = { values = [9.0, 10.0] }',
                          'a = { values = [9.0, 10.0] }\nprotocol = { along = "f" }')
    with pytest.raises(SpecError, match=re.escape(
            'observable "basins" with [sweep] protocol')):
        parse_spec(spec, PATH)


def test_the_size_guard_counts_the_attractor_slots():
    """A million points of basins in 8 slots is well within the output limit; in 1000
    slots (69 bytes a slot: 64.3 GiB) it is not."""
    parse_spec(text(num=500_000), PATH)
    with pytest.raises(SpecError, match=r"\[sweep\] f x a = 500000 x 2 = 1e\+06 points "
                                        r"\(64.3 GiB of output\)"):
        parse_spec(text(num=500_000, basins="[basins]\nmax_attractors = 1000\n"), PATH)


def test_the_variables_and_their_declarations():
    basins = OBSERVABLES["basins"]
    per_attractor = [v for v in basins.variables if VARIABLES[v].grid == "attractor"]
    assert per_attractor == ["basin_status", "basin_velocity", "basin_velocity_error",
                             "basin_largest_hop", "basin_period", "basin_multiplier",
                             "basin_exponent", "basin_fraction", "basin_fraction_low",
                             "basin_fraction_high"]
    assert [v for v in basins.variables if VARIABLES[v].grid == "point"] == [
        "attractor_count", "default_attractor", "starts_drawn"]
    assert VARIABLES["basin_status"].dtype == "int8"
    assert VARIABLES["basin_period"].dtype == "int32"
    assert VARIABLES["basin_fraction"].trailing({"attractor": 5}) == (5,)
    assert VARIABLES["basin_fraction"].trailing_shape == (8,)
    # attractor_count keeps the attractors observable's texts; basins has its own.
    count = VARIABLES["attractor_count"]
    assert count.texts(False, ("attractors",))[0].startswith("distinct stable outcomes")
    assert count.texts(True, ("basins",))[0].startswith("attractors reached from")
    row = next(line for line in markdown_table().splitlines() if line.startswith("| `basins`"))
    assert "`basin_fraction`" in row and "`default_attractor`" in row
