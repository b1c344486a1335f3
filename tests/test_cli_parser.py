"""The shared command-line pieces: a usage error is one line with exit 2, an output file's check
(exists / folder missing / --force) says the same thing in every command that writes one, and a
nested config's leaves are named by the dotted paths overrides use."""

import os

import pytest

from swim_jax.io import cli_parser


def test_usage_error_is_one_line_with_exit_2(capsys):
    p = cli_parser.ArgumentParser(prog="prog")
    p.add_argument("--n", type=int)
    with pytest.raises(SystemExit) as e:
        p.parse_args(["--n", "x"])
    err = capsys.readouterr().err
    assert e.value.code == 2
    assert err.count("\n") == 1 and err.startswith("prog: error: ") and err.endswith("(see --help)\n")


def test_output_file_problem(tmp_path):
    free, taken, orphan = tmp_path / "new.json", tmp_path / "old.json", tmp_path / "no" / "f.json"
    taken.write_text("kept")
    assert cli_parser.output_file_problem("--json", str(free)) is None
    assert cli_parser.output_file_problem("--json", str(taken)) == f"--json {taken} exists; nothing written"
    assert cli_parser.output_file_problem("--json", str(taken), force=False) == (
        f"--json {taken} exists; refusing to overwrite (use --force)")
    assert cli_parser.output_file_problem("--json", str(taken), force=True) is None
    for force in (None, False, True):
        assert cli_parser.output_file_problem("--out", str(orphan), force) == (
            f"--out {orphan}: folder {tmp_path / 'no'} does not exist")
    assert taken.read_text() == "kept" and not os.path.exists(orphan.parent)


def test_dotted_keys_names_every_leaf_by_its_override_path():
    tree = {"agent": {"tau": 0.005, "activation": {"k": 0.5}, "hidden": [256, 256]}, "seeds": 5, "env": {}}
    assert cli_parser.dotted_keys(tree) == {"agent.tau": 0.005, "agent.activation.k": 0.5, "agent.hidden": [256, 256],
                                          "seeds": 5}
    assert list(cli_parser.dotted_keys({"b": 1, "a": {"c": 2}})) == ["b", "a.c"]


def test_counted_writes_the_plural_only_for_counts_other_than_one():
    assert [cli_parser.counted(n, "seed") for n in (0, 1, 2, 5)] == ["0 seeds", "1 seed", "2 seeds", "5 seeds"]


def test_one_line_makes_an_exception_one_line_of_an_error_message():
    assert cli_parser.one_line(ValueError("bad value\n  in line 3\tof x.yaml")) == "bad value in line 3 of x.yaml"
    assert cli_parser.one_line(KeyError()) == "KeyError"  # no text: the type's name
    assert cli_parser.one_line(OSError("x" * 400)) == "x" * 300
    assert cli_parser.one_line(OSError("abcdef"), limit=3) == "abc"
