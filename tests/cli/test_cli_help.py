"""Every sub-command's ``--help`` has a description and examples, and what the commands print
fits 100 columns (issue "A library people can adopt", item 6).

The sub-commands are read off the top-level ``--help`` (its ``{build,transpile,...}`` list),
not from the parser's internals; each example line is parsed by the command's own parser.
"""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest
from qiskit import QuantumCircuit

from qdensity.cli.main import _parser, main
from qdensity.hardware.resources import compare_reports, resource_report
from qdensity_paper.cli.results import is_headline
from qdensity_paper.results import ExperimentResult


def _help(argv, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--help"])
    assert exc.value.code == 0
    return capsys.readouterr().out


def _choices(text: str) -> list[str]:
    match = re.search(r"\{([a-z0-9_,-]+)\}", text)
    assert match, text
    return match.group(1).split(",")


def _commands(capsys) -> list[list[str]]:
    top = _choices(_help([], capsys))
    out = [[c] for c in top]
    assert "results" in top and "build" in top
    out += [["results", c] for c in _choices(_help(["results"], capsys))]
    return out


def test_every_subcommand_help_has_a_description_and_examples_that_parse(capsys):
    commands = _commands(capsys)
    assert len(commands) >= 12
    for argv in commands:
        text = _help(argv, capsys)
        usage, _, body = text.partition("\n\n")
        description = body.split("\n\n")[0]
        assert not description.startswith(("positional", "options")), (argv, text[:300])
        assert len(description.split()) >= 8, (argv, description)
        assert "examples:" in text, argv
        examples = [line.strip() for line in text.split("examples:")[1].splitlines()
                    if line.strip().startswith("qdensity ")]
        assert examples, argv
        for line in examples:
            words = shlex.split(line.split("  #")[0])[1:]
            assert words[:len(argv)] == argv, (argv, line)
            _parser().parse_args(words)  # the example's options exist and parse


def test_help_lines_fit_100_columns(capsys):
    for argv in [[], *_commands(capsys)]:
        text = _help(argv, capsys)
        wide = [line for line in text.splitlines() if len(line) > 100]
        assert not wide, (argv, wide)


def test_experiment_list_speaks_of_the_paper_and_fits(capsys):
    assert main(["experiment", "--list"]) == 0
    text = capsys.readouterr().out
    assert max(len(line) for line in text.splitlines()) <= 100
    assert "Fig. 5" in text and "Supp. C" in text
    assert not re.search(r"\bissue\b", text, re.IGNORECASE)
    assert main(["experiment", "--list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert not any(re.search(r"\bissue\b", r["paper"], re.IGNORECASE) for r in rows)


def test_compare_reports_of_13_reports_fits_100_columns():
    qc = QuantumCircuit(4)
    for q in range(3):
        qc.cx(q, q + 1)
    reports = {f"device number {i} with a long name": resource_report(qc, "line" if i % 2
                                                                        else "ideal")
               for i in range(13)}
    text = compare_reports(reports)
    assert max(len(line) for line in text.splitlines()) <= 100
    # every report's column and every ratio appear once, under the legend's labels
    assert all(f"[{i + 1}] device number {i} with a long name" in text for i in range(13))
    header_cells = [c for line in text.splitlines() if line.startswith("metric")
                    for c in line.split()[1:]]
    assert header_cells == [f"[{i}]" for i in range(1, 14)] + [f"[{i}]/[1]" for i in
                                                              range(2, 14)]
    a, b = resource_report(qc), resource_report(qc, "line")
    assert compare_reports({"ideal": a, "line": b}).splitlines()[0].split() == [
        "metric", "ideal", "line", "line/ideal"]  # a narrow table keeps the names
    with pytest.raises(ValueError, match="width"):
        compare_reports({"a": a}, width=10)


def _result(tmp_path, mode: str, name: str = "mixing-lemma"):
    per_seed = [{"lemma/eps_1": 0.1 + 0.01 * s, "lemma/bound": 0.5, "lemma/distance_max": 0.2,
                 "circuits_per_row": 9, "seconds": 3.0} for s in range(2)]
    result = ExperimentResult(name=name, mode=mode, seeds=[0, 1], config={},
                              per_seed=per_seed)
    path = tmp_path / f"{name}-{mode}.json"
    path.write_text(json.dumps(result.to_dict()), encoding="utf-8")
    return path


def test_results_show_puts_headline_metrics_first_and_filters(tmp_path, capsys):
    path = _result(tmp_path, "quick")
    assert main(["results", "show", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == "headline metrics:"
    head = lines[2:lines.index("counts and sizes:")]
    assert {line.split()[0] for line in head} == {"lemma/eps_1", "lemma/bound",
                                                  "lemma/distance_max"}
    assert main(["results", "show", str(path), "--metric", "eps", "--json"]) == 0
    assert list(json.loads(capsys.readouterr().out)["summary"]) == ["lemma/eps_1"]
    assert main(["results", "show", str(path), "--metric", "lemma/*_max"]) == 0
    out = capsys.readouterr().out
    assert "lemma/distance_max" in out and "eps_1" not in out
    assert main(["results", "show", str(path), "--metric", "nothing"]) == 2
    assert "matches none" in capsys.readouterr().err
    assert not is_headline("D1/circuits/forward") and is_headline("D1/test_accuracy")


def test_results_report_in_any_folder_never_judges_a_quick_run(tmp_path, capsys,
                                                                monkeypatch):
    monkeypatch.chdir(tmp_path)  # no README.md or EXPERIMENTS.md here
    folder = tmp_path / "mine"
    folder.mkdir()
    _result(folder, "quick")
    assert main(["results", "report", "--dir", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "quick run: not judged" in out and "reproduced" not in out
    assert max(len(line) for line in out.splitlines()) <= 100
    assert main(["results", "report", "--dir", str(folder), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert rows and all(r["verdict"] == "quick run: not judged" for r in rows)
    assert main(["results", "report", "--dir", str(folder), "--write"]) == 2
    err = capsys.readouterr().err
    assert "README.md and EXPERIMENTS.md" in err and "not there" in err
    (tmp_path / "README.md").write_text("x\n")
    (tmp_path / "EXPERIMENTS.md").write_text("x\n")
    assert main(["results", "report", "--dir", str(folder), "--check"]) == 2
    assert "quick runs" in capsys.readouterr().err
    _result(folder, "full", name="noise")  # an experiment beyond the paper: no claims
    assert main(["results", "report", "--dir", str(folder)]) == 0
    assert "noise-full.json (full)\n  no claim of the paper" in capsys.readouterr().out
    assert main(["results", "report", "--dir", str(tmp_path / "absent")]) == 2
    assert "is not a folder" in capsys.readouterr().err


def test_results_report_prints_every_kind_of_estimate(capsys):
    """The text report of the committed results: superiority (95% interval), non-inferiority
    (90%), bounds and exact counts (mean and smallest margin), and estimates without an
    interval, each on lines of at most 100 characters."""
    folder = Path(__file__).resolve().parents[2] / "results"
    assert main(["results", "report", "--dir", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "(95%)" in out and "(90%)" in out and "smallest margin" in out
    assert max(len(line) for line in out.splitlines()) <= 100
