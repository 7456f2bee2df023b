"""Seeded mutations of every workflow spec: parsing either accepts or refuses cleanly.

Each case takes a workflow, applies one to three random mutations (a key deleted, a
value of the wrong type, a huge, tiny, negative, infinite or NaN value, a duplicated
line, an unknown key or table, non-UTF-8 bytes, another encoding, deep nesting, a
truncated file) and parses the result the way ``study run`` does (the kind first,
then the study or scene spec). The outcome must be a spec or a :class:`SpecError`
whose message starts with the file's name: never another exception, and no warning
(warnings are errors in the test suite) but a :class:`study.SuspectInputWarning` that
names the file (a tilt that looks like radians, issue 34).

The quick tier (1000 cases) runs with ``make test``; the slow tier (``make
test-slow``) runs 10 000 more. Only parsing is exercised here: running mutated specs
end to end is the fuzz tier's job.
"""

from __future__ import annotations

import random
import re
import traceback
import warnings
from pathlib import Path

import pytest

from study.engine.spec_files import SpecError, detect_kind
from study.model.inputs import SuspectInputWarning
from study.scenes.scene_spec import SceneSpec, load_scene
from study.studies.spec import StudySpec, load_spec

WORKFLOWS = sorted((Path(__file__).resolve().parents[2] / "workflows").glob("*.toml"))

#: Replacement values: wrong types, boundaries, huge, tiny, non-finite, odd TOML.
VALUES = (
    '"abc"', "''", '"14.2"', "-1", "0", "1", "-0.0", "0.5", "2", "1e300", "-1e300", "1e-300",
    "5e-324", "1.7976931348623157e308", "nan", "inf", "-inf", "9223372036854775807",
    "-9223372036854775808", "100000000000000000000", "10000000", "1000001", "true", "[]",
    "{}", "[1, 2]", "[[1, 2]]", "[1, 'x']", "{ values = [] }", "{ values = ['x'] }",
    "{ start = 1, stop = 2, num = 3 }", "{ start = 1, stop = 2, num = 0 }",
    '{ start = 1e-300, stop = 1e300, num = 10000000, spacing = "log" }', "1979-05-27",
    "07:32:00", "0x10", "1_000", "[0.0, 0.0]", "[[0.0, 0.0]]", '"trajectory"', '"two-way"',
)
_KEY_LINE = re.compile(r"^(\s*[A-Za-z0-9_.\"-]+\s*=\s*)(.*?)(\s*#.*)?$")
_NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.])")


def _key_lines(lines: list[str]) -> list[int]:
    return [i for i, line in enumerate(lines) if _KEY_LINE.match(line) and "=" in line]


def _nested(rng: random.Random) -> str:
    depth = rng.choice([3, 8, 9, 40, 2000])
    if rng.random() < 0.5:
        return "[" * depth + "1" + "]" * depth
    return "{ x = " * depth + "1" + " }" * depth


def mutate(text: str, rng: random.Random) -> tuple[bytes, str]:
    """One to three random mutations of a spec's text: the bytes and what was done."""
    done = []
    data: bytes | None = None
    for _ in range(rng.choice([1, 1, 2, 3])):
        lines = text.splitlines()
        keyed = _key_lines(lines)
        kind = rng.choice([
            "delete", "value", "value", "number", "number", "duplicate", "unknown-key",
            "unknown-table", "rename-table", "nest", "truncate", "wrap", "bytes", "encoding",
            "drop-table",
        ])
        if kind == "delete" and lines:
            i = rng.randrange(len(lines))
            done.append(f"delete line {i + 1}: {lines[i][:40]!r}")
            del lines[i]
        elif kind == "value" and keyed:
            i = rng.choice(keyed)
            value = rng.choice(VALUES)
            lines[i] = _KEY_LINE.sub(lambda m, v=value: m.group(1) + v, lines[i])
            done.append(f"line {i + 1} value -> {value}")
        elif kind == "number" and _NUMBER.search(text):
            found = list(_NUMBER.finditer(text))
            match = rng.choice(found)
            value = rng.choice(VALUES)
            text = text[: match.start()] + value + text[match.end():]
            done.append(f"number {match.group()!r} at {match.start()} -> {value}")
            continue
        elif kind == "duplicate" and lines:
            i = rng.randrange(len(lines))
            lines.insert(i, lines[i])
            done.append(f"duplicate line {i + 1}")
        elif kind == "unknown-key" and lines:
            i = rng.randrange(len(lines) + 1)
            lines.insert(i, "bogus_key = 1")
            done.append(f"unknown key at line {i + 1}")
        elif kind == "unknown-table":
            lines.append(rng.choice(["[bogus]\nx = 1", "[[bogus]]\nx = 1", "[solver]\nx = 1",
                                     "[study]\nname = 'x'", "[scene]\nname = 'x'"]))
            done.append("extra table")
        elif kind == "rename-table":
            headers = [i for i, line in enumerate(lines) if line.startswith("[")]
            if headers:
                i = rng.choice(headers)
                lines[i] = lines[i].replace("]", "x]", 1)
                done.append(f"rename table at line {i + 1}")
        elif kind == "drop-table":
            headers = [i for i, line in enumerate(lines) if line.startswith("[")]
            if headers:
                i = rng.choice(headers)
                done.append(f"drop header {lines[i]!r}")
                del lines[i]
        elif kind == "nest" and keyed:
            i = rng.choice(keyed)
            lines[i] = _KEY_LINE.sub(lambda m: m.group(1) + _nested(rng), lines[i])
            done.append(f"line {i + 1} nested")
        elif kind == "truncate" and text:
            cut = rng.randrange(len(text))
            text = text[:cut]
            done.append(f"truncated at {cut}")
            continue
        elif kind == "wrap" and keyed:
            i = rng.choice(keyed)
            how = rng.choice(['"{}"', "[{}]", "{{ x = {} }}", "[[{}]]"])
            lines[i] = _KEY_LINE.sub(lambda m, h=how: m.group(1) + h.format(m.group(2)),
                                     lines[i])
            done.append(f"line {i + 1} wrapped as {how}")
        elif kind == "bytes":
            raw = text.encode()
            at = rng.randrange(len(raw) + 1)
            junk = rng.choice([b"\xff", b"\xc3\x28", b"\x00", b"\xed\xa0\x80", b"\xef\xbb\xbf"])
            data = raw[:at] + junk + raw[at:]
            done.append(f"bytes {junk!r} at {at}")
            break
        elif kind == "encoding":
            encoding = rng.choice(["utf-16", "utf-16-le", "utf-32", "latin-1", "cp1252"])
            data = text.replace("degree", "°").encode(encoding, errors="replace")
            done.append(f"encoded as {encoding}")
            break
        text = "\n".join(lines) + "\n"
    if data is None:
        data = text.encode("utf-8", errors="surrogatepass")
    return data, "; ".join(done) or "unchanged"


def parse_like_the_cli(path: Path) -> StudySpec | SceneSpec:
    """The kind, then the spec: what ``study run`` does before any work."""
    if detect_kind(path) == "scene":
        return load_scene(path)
    return load_spec(path)


def run_cases(tmp_path: Path, seed: int, count: int) -> dict[str, int]:
    rng = random.Random(seed)
    texts = {path.name: path.read_text(encoding="utf-8") for path in WORKFLOWS}
    outcomes = {"accepted": 0, "refused": 0}
    failures = []
    for case in range(count):
        name = rng.choice(sorted(texts))
        data, what = mutate(texts[name], rng)
        path = tmp_path / f"case-{case}-{name}"
        path.write_bytes(data)
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", SuspectInputWarning)
                spec = parse_like_the_cli(path)
            for warning in caught:
                if not str(warning.message).startswith(f"{path}: "):
                    failures.append(f"{path.name} ({what}): a warning without the file: "
                                    f"{warning.message}")
        except SpecError as err:
            outcomes["refused"] += 1
            if not str(err).startswith(f"{path}: "):
                failures.append(f"{path.name} ({what}): refusal without the file: {err}")
        except Exception:  # any other exception is what this test finds
            failures.append(f"{path.name} ({what}):\n{traceback.format_exc(limit=-3)}")
        else:
            outcomes["accepted"] += 1
            assert isinstance(spec, StudySpec | SceneSpec)
        path.unlink()
    assert not failures, f"{len(failures)} of {count} cases crashed:\n" + "\n".join(failures[:10])
    return outcomes


def test_mutated_specs_parse_or_are_refused(tmp_path):
    outcomes = run_cases(tmp_path, seed=20240611, count=1000)
    # The mutations must exercise both outcomes, or the test would prove nothing.
    assert outcomes["refused"] > 500
    assert outcomes["accepted"] > 20


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_many_mutated_specs_parse_or_are_refused(tmp_path, seed):
    outcomes = run_cases(tmp_path, seed=seed, count=2500)
    assert outcomes["refused"] > 1000
