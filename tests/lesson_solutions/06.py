# Reference solution of lesson 06 (injected in place of the exercise cell by the tests).
# ruff: noqa: F821  (Experiment and sweep come from the lesson's earlier cells)
from pyautonomousagent.experiments.plot import summarize

energy = Experiment.from_mapping(
    {
        "scenario": "patrol",
        "iterations": 2500,
        "set": {"agents": 4, "low_energy_threshold": 40},
        "vary": {"energy_use": [0.03, 0.04, 0.05]},
        "seeds": 3,
        "measures": ["minimum_energy"],
    }
)
table = sweep(energy, "runs/sweeps/energy", backend="serial", progress=False).table
rows = summarize(table, "minimum_energy", "energy_use", None, "ci95")
best = min(rows, key=lambda row: row["mean"])["x"]
