"""``pyaa bench``: cases measured in their own process, the table, JSON and the stress search."""

from __future__ import annotations

import json

import pytest

from pyautonomousagent import bench
from pyautonomousagent.cli import main


def fake(
    engine: str, agents: int, seconds: float | None, peak: float | None = 100.0
) -> bench.Result:
    return bench.Result(
        bench.Case("patrol", engine, agents, 4000, 1), seconds, peak, "" if seconds else "over 5 MB"
    )


def test_speedups_pair_engines_with_the_same_agents() -> None:
    results = [fake("pytrees", 10, 2.0), fake("batched", 10, 0.5), fake("batched", 100, 1.0)]
    ratios = bench.speedups(results, "pytrees")
    assert ratios == {results[1].case: 4.0}


def test_table_has_the_papers_figures_and_failures() -> None:
    text = bench.table(
        [fake("pytrees", 100, 20.0), fake("batched", 100, 0.2), fake("batched", 1000, None, None)],
        "pytrees",
    )
    lines = text.splitlines()
    assert "speed-up" in lines[0] and "paper s" in lines[0]
    assert "100x" in lines[3] and "17.32" in lines[3]
    assert "failed: over 5 MB" in lines[4]


@pytest.mark.parametrize(
    ("text", "mb"), [("5.12GB", 5.12 * 1024), ("300MB", 300.0), ("2048kb", 2.0), ("64", 64.0)]
)
def test_sizes(text: str, mb: float) -> None:
    assert bench.parse_size_mb(text) == pytest.approx(mb)


def test_stress_doubles_then_bisects(monkeypatch: pytest.MonkeyPatch) -> None:
    def measure(
        case: bench.Case, timeout: float | None = None, budget_mb: float | None = None
    ) -> bench.Result:
        return bench.Result(case, 1.0, 50.0 + case.agents / 100)  # 1 MB per 100 agents

    monkeypatch.setattr(bench, "measure", measure)
    found, probes = bench.stress("patrol", "batched", 250.0, 5, 6, start=1000)
    assert 19_600 <= found <= 20_000
    assert [p.case.agents for p in probes][:6] == [1000, 2000, 4000, 8000, 16000, 32000]


def test_a_real_case_runs_in_its_own_process() -> None:
    result = bench.measure(bench.Case("patrol", "batched", 3, 30, 1))
    assert result.error == ""
    assert result.seconds is not None and result.seconds > 0
    assert result.peak_mb is not None and result.peak_mb > 10


def test_cli_prints_the_table_and_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "patrol", "--agents", "2", "--iterations", "20"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0].split()[:3] == ["agents", "engine", "record"]
    assert [line.split()[1] for line in table[2:]] == ["pytrees", "batched"]
    assert table[3].split()[6].endswith("x")  # the batched row has its speed-up
    assert (
        main(
            [
                "bench",
                "patrol",
                "--agents",
                "2",
                "--iterations",
                "10",
                "--engines",
                "batched",
                "--record-every",
                "1,5",
                "--json",
            ]
        )
        == 0
    )
    rows = json.loads(capsys.readouterr().out)
    assert [(r["engine"], r["record_every"]) for r in rows] == [("batched", 1), ("batched", 5)]


@pytest.mark.parametrize(
    "args",
    [
        ["bench", "nope"],
        ["bench", "patrol", "--engines", "x"],
        ["bench", "patrol", "--agents", "0"],
        ["bench", "patrol", "--agents", "a,b"],
        ["bench", "patrol", "--stress-iterations", "0"],
        ["bench", "patrol", "--reference-iterations", "-1"],
    ],
)
def test_cli_refuses_bad_input(args: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(args) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_stress_probes_are_sized_for_the_full_run(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[bench.Case] = []

    def measure(
        case: bench.Case, timeout: float | None = None, budget_mb: float | None = None
    ) -> bench.Result:
        seen.append(case)
        return bench.Result(case, 1.0, 10.0 * case.agents)

    monkeypatch.setattr(bench, "measure", measure)
    bench.stress("patrol", "batched", 25.0, 5, 100, start=1, full_iterations=4000)
    assert seen and all(case.full_iterations == 4000 for case in seen)


@pytest.mark.parametrize(("ratio", "shown"), [(0.57, "0.57x"), (3.24, "3.2x"), (48.4, "48x")])
def test_speedups_below_ten_keep_two_digits(ratio: float, shown: str) -> None:
    assert bench.format_ratio(ratio) == shown


def test_a_slower_engine_shows_its_fraction() -> None:
    text = bench.table([fake("pytrees", 10, 1.0), fake("batched", 10, 1.75)], "pytrees")
    assert "0.57x" in text.splitlines()[3]


@pytest.mark.parametrize(
    ("maxrss", "system", "mb"),
    [(2048 * 1024, "linux", 2048.0), (2048 * 1024 * 1024, "darwin", 2048.0)],
)
def test_peak_memory_units_per_system(maxrss: int, system: str, mb: float) -> None:
    assert bench.peak_rss_mb(maxrss, system) == mb


@pytest.mark.parametrize("text", ["lots", "-5GB", "0", "nanMB", "inf", ""])
def test_bad_sizes_are_refused(text: str) -> None:
    with pytest.raises(ValueError, match="expected a positive size"):
        bench.parse_size_mb(text)


def test_gathering_runs_at_its_own_size_and_times_each_stage(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["bench", "gathering", "--engines", "pytrees,batched", "--iterations", "20"]
    assert main([*argv, "--save", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["engine"], r["agents"], r["iterations"]) for r in rows] == [
        ("pytrees", 4, 20),
        ("batched", 4, 20),
    ]
    for row in rows:
        assert row["setup_s"] > 0 and row["loop_s"] > 0 and row["write_s"] > 0
        assert row["views_s"] > 0
        assert row["seconds"] == pytest.approx(row["setup_s"] + row["loop_s"])


def test_table_marks_stages_not_measured() -> None:
    saved = bench.Result(bench.Case("patrol", "batched", 10, 4000, 1), 1.5, 80.0, setup=0.5,
                         write=0.25, views=2.0)  # fmt: skip
    lines = bench.table([fake("batched", 10, 1.0), saved], "pytrees").splitlines()
    assert lines[0].split()[-4:] == ["set-up", "loop", "write", "views"]
    assert lines[2].split()[-2:] == ["-", "-"]
    assert lines[3].split()[-4:] == ["0.500", "1.000", "0.250", "2.000"]
