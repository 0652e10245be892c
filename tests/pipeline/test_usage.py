"""The CPU time of a build's tasks, summed from their logs (nnmstop.pipeline.usage)."""

from nnmstop.pipeline.usage import main, read_usage


def line(task: str, where: str, cpu: float, user: float, system: float, memory: int, outcome="finished") -> str:
    return (
        f"INFO nnmstop.pipeline.run: task {task} ran {where}: 1.00 s wall, {cpu:.2f} s CPU (user {user:.2f} s, "
        f"system {system:.2f} s), {memory} MB peak resident; {outcome}\n"
    )


def test_the_cost_lines_of_every_log_are_summed_per_task_and_in_total(tmp_path, capsys):
    (tmp_path / "hbm").mkdir()
    (tmp_path / "hbm" / "nnm1_stage1.log").write_text(
        "INFO nnmstop.hbm.stages: a line of the task\n" + line("hbm_stage", "in the warm worker", 2.5, 2.25, 0.25, 300)
    )
    (tmp_path / "hbm" / "nnm1_stage2.log").write_text(line("hbm_stage", "in the warm worker", 1.25, 1.0, 0.25, 310))
    (tmp_path / "fig02.log").write_text(
        line("paper_fig02", "in its own process", 4.0, 3.5, 0.5, 200, outcome="interrupted by SIGTERM")
    )
    (tmp_path / "other.txt").write_text(line("ignored", "in the warm worker", 99.0, 99.0, 0.0, 1))
    usages = read_usage(tmp_path)
    found = sorted((u["task"], u["cpu"]) for u in usages)
    assert found == [("hbm_stage", 1.25), ("hbm_stage", 2.5), ("paper_fig02", 4.0)]
    assert main([str(tmp_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    hbm = next(row for row in out if row.startswith("hbm_stage"))
    assert hbm.split()[1:] == ["2", "3.75", "0.00", "310"]
    assert out[-1].split()[1:4] == ["3", "3.75", "4.00"] and "all tasks: 7.75 s CPU" in out[-1]


def test_a_missing_log_folder_or_no_cost_line_is_said(tmp_path, capsys):
    assert main([str(tmp_path / "nowhere")]) == 2
    (tmp_path / "a.log").write_text("INFO nothing to sum\n")
    assert main([str(tmp_path)]) == 1
    assert "no task cost line" in capsys.readouterr().err
