"""Reading params files: the fast YAML path gives PyYAML's document exactly; large systems are checked at once."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from pmr_ros.config import ConfigError, config_dir, load_config
from pmr_ros.config.fast_yaml import LARGE_TEXT, load

PYYAML = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

TRICKY = """\
a: [1, 2.5, -3, +4.0e-3, 0, -0, 7.]
b: "[1, 2]"
c: '[1, 2] and more'
d: plain [1, 2] text
# a comment [1, 2]
e: |
  a block [1, 2]
  scalar
f: !!seq [1, 2]
g: &anchored [1, 2]
h: *anchored
i: [[1, 2], [3.5, 4]]
j: [1e5, 2, 1.0e5, 1.0e+5]
k: [010, 2, 0x1F, 1_000, 190:20:30]
l: [.5, 1., -.inf, .nan]
m: {x: [1, 2], y: [3]}
n: [ 1 ,2 , ]
o: [1,
    2]
p: [!!float 1, !!int 2, !!str 3]
q: "a [1, 2]
  folded"
r: [1, 2] # trailing [3, 4]
s: [true, 1, null]
t: ["1", 2]
u: {[1, 2]: x}
"""


def _same(a, b) -> bool:
    """Equal and of the same types all the way down (1 and 1.0 differ; NaN equals NaN)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and a != a:
        return b != b
    return a == b


def _large(text: str) -> str:
    """``text`` padded past :data:`LARGE_TEXT` with a long number list, so the cut-out path runs."""
    rng = np.random.default_rng(0)
    pad = ", ".join(f"{x:.6f}" for x in rng.normal(size=LARGE_TEXT // 8))
    return f"{text}pad: [{pad}]\n"


@pytest.mark.parametrize("size", ["small", "large"])
def test_fast_loading_gives_pyyamls_document_exactly(size):
    lines = [line for line in TRICKY.splitlines(keepends=True) if not line.startswith("u:")]
    text = "".join(lines)
    if size == "large":
        text = _large(text)
        assert len(text) >= LARGE_TEXT
    expected = yaml.load(text, Loader=PYYAML)  # noqa: S506 - a safe loader
    # pmr_ros's number grammar (config.numbers), not YAML 1.1's: 1e5 is a number, 010 ten, 0x1F and 1_000 text
    expected["j"], expected["k"] = [1e5, 2, 1e5, 1e5], [10, 2, "0x1F", "1_000", "190:20:30"]
    got = load(text)
    assert _same(got, expected)
    assert got["b"] == "[1, 2]" and got["q"] == "a [1, 2] folded" and got["j"][0] == 1e5
    assert got["h"] is got["g"] and got["k"][0] == 10


@pytest.mark.parametrize("size", ["small", "large"])
def test_fast_loading_fails_as_pyyaml_does(size):
    for text in ("u: {[1, 2]: x}\n", "a: [1, 2\nb: 3\n", 'x: "\\[1, 2]"\n', "a: [1, 2]]\n"):
        text = _large(text) if size == "large" else text
        with pytest.raises(yaml.YAMLError) as expected:
            yaml.load(text, Loader=PYYAML)  # noqa: S506 - a safe loader
        with pytest.raises(yaml.YAMLError) as got:
            load(text)
        assert str(got.value) == str(expected.value)


def _outcome(loader, text: str):
    try:
        return "value", loader(text)
    except yaml.YAMLError as exc:
        return "error", str(exc)


def test_random_documents_give_the_same_document_or_error_with_both_loaders():
    rng = np.random.default_rng(7)
    fragments = [
        line.split(": ", 1)[1]
        for line in TRICKY.splitlines()
        if ": " in line and not line.startswith((" ", "j:", "k:"))  # j, k: the number grammar differs from YAML 1.1's
    ]
    fragments += ["[1, 2]]", "[1, 2] x", "[[1, 2] x]", "*nowhere", "[1, 2] # [3, 4]"]
    for _ in range(40):
        chosen = rng.choice(len(fragments), size=6, replace=False)
        body = "".join(f"k{j}: {fragments[c]}\n" for j, c in enumerate(chosen))
        text = _large(body)
        expected = _outcome(lambda t: yaml.load(t, Loader=PYYAML), text)  # noqa: S506 - a safe loader
        got = _outcome(load, text)
        assert got[0] == expected[0] and (_same(got[1], expected[1]) if got[0] == "value" else got[1] == expected[1])


def _big_system(path, n: int, bad: str | None = None) -> None:
    rng = np.random.default_rng(0)
    gains = [f"{x:.6f}" for x in rng.uniform(0.5, 2.0, n * n)]
    if bad is not None:
        gains[-1] = bad
    names = ", ".join(f"y{i}" for i in range(n))
    inputs = ", ".join(f"u{i}" for i in range(n))
    taus = ", ".join(f"{x:.6f}" for x in rng.uniform(5.0, 20.0, n * n))
    delays = ", ".join(f"{d}.0" for d in rng.integers(0, 5, n * n))
    path.write_text(
        "/**:\n  ros__parameters:\n    system:\n      sample_time: 1.0\n"
        f"      output_names: [{names}]\n      input_names: [{inputs}]\n"
        f"      gain: [{', '.join(gains)}]\n      time_constant: [{taus}]\n      delay: [{delays}]\n"
        "    mpc:\n      prediction_horizon: 40\n"
    )


def test_a_large_system_reads_as_the_slow_path_would(tmp_path):
    _big_system(tmp_path / "big.yaml", 120)
    assert (tmp_path / "big.yaml").stat().st_size > LARGE_TEXT
    config = load_config(tmp_path / "big.yaml")
    params = yaml.load((tmp_path / "big.yaml").read_text(), Loader=PYYAML)["/**"]["ros__parameters"]  # noqa: S506
    np.testing.assert_array_equal(config.model.gain.ravel(), params["system"]["gain"])
    np.testing.assert_array_equal(config.model.time_constant.ravel(), params["system"]["time_constant"])
    assert config.model.n_outputs == config.model.n_inputs == 120


@pytest.mark.parametrize(
    "bad,words",
    [("-0.0", "must be non-zero"), ("true", "must be a number"), ("0x1F", "must be a number"), (".nan", "finite")],
)
def test_one_bad_number_in_a_large_matrix_is_named(tmp_path, bad, words):
    _big_system(tmp_path / "big.yaml", 120, bad=bad)
    with pytest.raises(ConfigError) as err:
        load_config(tmp_path / "big.yaml")
    text = str(err.value)
    assert "system.gain[14399] (G120_120)" in text and words in text and "\n" not in text


def test_a_number_too_large_for_a_float_is_one_line(tmp_path):
    base = (config_dir() / "wood_berry.yaml").read_text()
    (tmp_path / "huge.yaml").write_text(base + "    noise:\n      std: " + "9" * 400 + "\n")
    with pytest.raises(ConfigError) as err:
        load_config(tmp_path / "huge.yaml")
    assert "noise.std = 999" in str(err.value) and "must be finite" in str(err.value) and "\n" not in str(err.value)
