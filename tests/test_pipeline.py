"""Command line of the workflow tasks (nnmstop.tasks.run)."""

import pytest

from nnmstop.tasks import run as pipeline


def test_command_line_passes_named_files_and_wildcards(monkeypatch, repo_root, tmp_path):
    seen = {}

    def fake_task(config, inputs, outputs, **wildcards):
        seen.update(inputs=inputs, outputs=outputs, wildcards=wildcards, alpha=config["model"]["alpha"])

    monkeypatch.setitem(pipeline.TASKS, "study_error_case", fake_task)
    pipeline.main([
        "study_error_case", "--config", str(repo_root / "config" / "config.yaml"),
        "--input", "exact=results/exact/nnm1_two_impacts.nc", "--output", f"dataset={tmp_path / 'case.nc'}",
        "--wildcard", "harmonics=100", "--wildcard", "eta=0.1", "--log", str(tmp_path / "case.log"),
    ])
    assert seen["wildcards"] == {"harmonics": "100", "eta": "0.1"}
    assert seen["inputs"] == {"exact": "results/exact/nnm1_two_impacts.nc"}
    assert seen["alpha"] == 30.0


def test_command_line_refuses_a_repeated_wildcard(repo_root, capsys):
    with pytest.raises(SystemExit):
        pipeline.main(["study_error_case", "--config", str(repo_root / "config" / "config.yaml"),
                       "--wildcard", "eta=0.1", "--wildcard", "eta=0.2"])
    assert "wildcard 'eta' given more than once" in capsys.readouterr().err
