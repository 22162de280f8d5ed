"""The evaluation's tables: paper Table 4 (RUL RMSE per run) and the means of every other
metric, for the terminal or as Markdown."""

from __future__ import annotations

from typing import Any

from brake_env.output import table


def _num(x: Any, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def rmse_table(metrics: dict[str, Any], markdown: bool = False) -> str:
    """Paper Table 4: RUL RMSE per run (R1..Rn) and mean, rows models, a block per split."""
    blocks = []
    for split, info in metrics["splits"].items():
        n = len(info["runs"])
        rows = [[f"{split.upper()} model", *(f"R{i + 1}" for i in range(n)), "Mean"]]
        for name, model in metrics["models"].items():
            s = model["splits"][split]
            vals = [s["runs"][r]["rul_rmse"] for r in info["runs"]]
            rows.append([name, *(_num(v, ".0f") for v in vals), _num(s["mean"]["rul_rmse"], ".0f")])
        title = f"{split.upper()} runs: " + ", ".join(
            f"R{i + 1}={r}" for i, r in enumerate(info["runs"])
        )
        blocks.append(("**" + title + "**" if markdown else title) + "\n\n" + table(rows, markdown))
    return "\n\n".join(blocks)


def summary_table(metrics: dict[str, Any], markdown: bool = False) -> str:
    """Means over runs: RMSE, convergence (fraction of life), RA, alpha-lambda, prognostic
    horizon (fraction of life), cumulative RA, monotonicity, PHM08, states; ``-`` for a
    metric the results do not hold."""
    first_model = next(iter(metrics["models"].values()))
    tols = next(iter(first_model["splits"].values()))["mean"]["convergence_frac"]
    rows = [
        [
            "model",
            "split",
            "RMSE",
            "RMSE/life",
            *(f"conv {float(t):.0%}" for t in tols),
            "RA",
            "a-l",
            "PH",
            "CRA",
            "mono",
            "PHM08",
            "vol RMSE",
            "K err",
            "coverage",
        ]
    ]
    for name, model in metrics["models"].items():
        for split, s in model["splits"].items():
            mu = s["mean"]
            k = mu.get("k_rel_error")
            rows.append(
                [
                    name,
                    split,
                    _num(mu["rul_rmse"], ".0f"),
                    _num(mu["rul_rmse_frac"], ".3f"),
                    *(_num(mu["convergence_frac"][t], ".2f") for t in tols),
                    _num(mu["relative_accuracy"], ".2f"),
                    _num(mu["alpha_lambda"], ".1f"),
                    _num(mu.get("prognostic_horizon_frac"), ".2f"),
                    _num(mu.get("cumulative_relative_accuracy"), ".2f"),
                    _num(mu.get("monotonicity"), ".2f"),
                    _num(mu["phm08"], ".3g"),
                    _num(mu.get("volume_rmse"), ".4f"),
                    _num(k["mean"] if k else None, ".3f"),
                    _num(mu.get("interval_coverage"), ".2f"),
                ]
            )
    return table(rows, markdown)
