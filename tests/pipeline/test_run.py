"""The task dispatcher and its command line (nnmstop.pipeline.run)."""

import importlib
import re

import pytest

from nnmstop.pipeline import run as pipeline


def test_command_line_passes_named_files_and_wildcards(monkeypatch, repo_root, tmp_path):
    seen = {}

    def fake_task(config, inputs, outputs, **wildcards):
        seen.update(inputs=inputs, outputs=outputs, wildcards=wildcards, alpha=config["model"]["alpha"])

    monkeypatch.setattr(pipeline, "find_task", lambda name: fake_task if name == "study_error_case" else None)
    pipeline.main(
        [
            "study_error_case",
            "--config",
            str(repo_root / "config" / "config.yaml"),
            "--input",
            "exact=results/exact/nnm1_two_impacts.nc",
            "--output",
            f"dataset={tmp_path / 'case.nc'}",
            "--wildcard",
            "harmonics=100",
            "--wildcard",
            "eta=0.1",
            "--log",
            str(tmp_path / "case.log"),
        ]
    )
    assert seen["wildcards"] == {"harmonics": "100", "eta": "0.1"}
    assert seen["inputs"] == {"exact": "results/exact/nnm1_two_impacts.nc"}
    assert seen["alpha"] == 30.0


def test_command_line_refuses_a_repeated_wildcard(repo_root, capsys):
    with pytest.raises(SystemExit):
        pipeline.main(
            [
                "study_error_case",
                "--config",
                str(repo_root / "config" / "config.yaml"),
                "--wildcard",
                "eta=0.1",
                "--wildcard",
                "eta=0.2",
            ]
        )
    assert "wildcard 'eta' given more than once" in capsys.readouterr().err


def test_unknown_task_is_refused_naming_the_tasks():
    with pytest.raises(ValueError, match=r"unknown task 'exact_tree'; tasks are \[.*'exact_two_impacts'"):
        pipeline.run_task("exact_tree", {})


def script_rules(rule_file) -> list[str]:
    """Rules of a rule file that run a task (script run_task.py)."""
    rules = re.split(r"^rule (\w+):", rule_file.read_text(), flags=re.MULTILINE)[1:]
    return [name for name, body in zip(rules[::2], rules[1::2], strict=True) if "scripts/run_task.py" in body]


def test_every_rule_runs_the_task_of_its_name_from_the_module_of_its_rule_file(repo_root):
    """workflow/rules/<file>.smk -> nnmstop.tasks.<file>, and every task module belongs to a rule file."""
    rule_files = sorted((repo_root / "workflow" / "rules").glob("*.smk"))
    covered = set()
    for rule_file in rule_files:
        for rule in script_rules(rule_file):
            module = pipeline.task_module(rule)
            covered.add(rule)
            # tasks whose bodies still wait in nnmstop.pipeline.run for their module (issue 12)
            assert module in (f"nnmstop.tasks.{rule_file.stem}", "nnmstop.pipeline.run"), (rule, module)
            assert callable(pipeline.find_task(rule))
    assert len(covered) > 30
    assert {f.stem for f in rule_files if script_rules(f)} == set(pipeline.TASK_MODULES)
    # and no task without a rule
    assert set(pipeline.task_table()) == covered


def test_the_task_index_matches_the_task_modules():
    """The dispatcher imports one module per job from TASK_INDEX: it must list exactly each module's TASKS."""
    for module, names in pipeline.TASK_INDEX.items():
        tasks = pipeline._module_tasks(importlib.import_module(f"nnmstop.tasks.{module}"))
        assert set(tasks) == set(names), module
