"""``topomap eval labels``: load the labelled sources, score every method in-sample and with
whole buildings left out, print the tables and the thresholds' margins, write results.json,
a picture per map and, on request, the forest trained on everything (skops)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from maps.files import write_text
from topomap.classifiers import RuleClassifier, rule_classifier
from topomap.cli import label_sources
from topomap.cli.evaluate_labels import (
    METHODS,
    VIEWS,
    draw_labels,
    evaluate,
    margins,
    mistakes,
    region_records,
    rule_changes,
    train_forest,
)
from topomap.cli.tables import markdown_table

#: The method whose labels the pictures and the per-map table show.
SHOWN = "rules (LOBO)"


def load_sources(args: argparse.Namespace) -> list[label_sources.LabelledMap]:
    """Every source the options name, in a fixed order."""
    hand = Path(args.hand_labels)
    maps = label_sources.ipa_places(args.data, progress=args.progress)
    if args.rose2:
        maps += label_sources.rose2(args.rose2, hand / "rose2_partial.csv", args.progress)
    if args.carmen:
        maps += label_sources.carmen(args.carmen, hand / "carmen.json", args.progress)
    if args.generated:
        maps += label_sources.generated(scanned=(0, 1, 2), progress=args.progress)
    return maps


def score_rows(result: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per method, mode and source: macro-F1 and corridor / hall precision, recall."""
    rows = []
    for method, found in result.items():
        for source, s in found["scores"].items():
            row = {"method": method, "source": source, "macro-F1": s["macro_f1"]}
            for place in ("corridor", "hall"):
                c = s["per_class"].get(place)
                row[place] = f"{c['precision']} / {c['recall']} ({c['support']})" if c else "-"
            rows.append(row)
    return rows


def lobo_by_source(result: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per method: its leave-one-building-out macro-F1 per source and over all.

    Examples
    --------
    >>> scores = {"a": {"macro_f1": 0.5}, "all": {"macro_f1": 0.4}}
    >>> lobo_by_source({"rules (LOBO)": {"scores": scores}, "rules (in-sample)": {}})
    [{'method': 'rules', 'a': 0.5, 'all': 0.4}]
    """
    return [
        {"method": m.removesuffix(" (LOBO)")} | {s: v["macro_f1"] for s, v in r["scores"].items()}
        for m, r in result.items()
        if m.endswith("(LOBO)")
    ]


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Run the evaluation the options ask for, print it and write its files into ``args.out``;
    returns what results.json holds."""
    out = Path(args.out)
    maps = load_sources(args)
    args.progress.stage(f"scoring {len(METHODS)} methods on {len(maps)} maps")
    result = evaluate(maps)
    rows = score_rows(result)
    print(f"{sum(len(m.truth) for m in maps)} labelled regions on {len(maps)} maps")
    print("macro-F1, corridor and hall precision / recall (support); LOBO: whole buildings")
    print("left out of whatever the method learns; 'all': every source but", ", ".join(VIEWS))
    print(markdown_table(rows, ["method", "source", "macro-F1", "corridor", "hall"]))
    lobo = {m: r["scores"]["all"]["macro_f1"] for m, r in result.items() if m.endswith("(LOBO)")}
    best = max(lobo, key=lambda m: lobo[m])
    print(f"\nbest LOBO macro-F1 over all sources: {best} ({lobo[best]})")
    per_source = lobo_by_source(result)
    print("LOBO macro-F1 per source (the default classifier is chosen by the 'all' column):")
    print(markdown_table(per_source, list(per_source[0])))
    found = margins(maps, rule_classifier)
    print("\nmargins of the default rules' thresholds (others fixed; macro-F1 on all sources")
    print("stays within 0.01 from 'lowest' to 'highest'; 'range' is what was searched):")
    why = {name: text for name, (_, _, text) in RuleClassifier.thresholds().items()}
    print(
        markdown_table(
            [{"threshold": k, **v, "why": why[k]} for k, v in found.items()],
            ["threshold", "value", "lowest", "highest", "range", "why"],
        )
    )
    changes = rule_changes(maps, rule_classifier)
    print("\nwhat each rule of the default changes (regions right with it only / without it only):")
    print(markdown_table(changes, list(changes[0])))
    shown = result[SHOWN]["labels"]
    per_map = mistakes(maps, shown)
    print(f"\nper map, {SHOWN}:")
    print(markdown_table(per_map, list(per_map[0])))
    out.mkdir(parents=True, exist_ok=True)
    for m, labels in zip(maps, shown, strict=True):
        draw_labels(out / f"{m.source}_{m.map}_labels.png", m, labels)
    results = {
        "scores": rows,
        "best_lobo": best,
        "lobo_by_source": per_source,
        "margins": found,
        "rule_changes": changes,
        "per_map": per_map,
        "regions": region_records(maps, result),
    }
    write_text(out / "results.json", json.dumps(results, indent=2), overwrite=True)
    print(f"wrote {out / 'results.json'} and a picture per map ({SHOWN}) to {out}")
    if args.save_model:
        model = train_forest([m for m in maps if m.source not in VIEWS])
        print(f"wrote {model.save(args.save_model)} (forest trained on all labelled regions)")
        print(
            f"its LOBO macro-F1 over all sources {lobo['forest (LOBO)']}, the rules' "
            f"{lobo['rules (LOBO)']}: use it where it is the better ({best} is the best here)"
        )
    return results
