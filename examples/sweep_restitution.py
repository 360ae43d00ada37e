"""Sweep the restitution and the number of rocks in scenes/spawners.ron (a gas of rocks and
tetrahedra in a closed box, no gravity) and see how much kinetic energy is left: the less
bouncy the rocks and the more of them, the faster the gas cools.

    python examples/sweep_restitution.py                    # on Ray (RAY_ADDRESS, or a local cluster)
    python examples/sweep_restitution.py --backend local    # on this machine's cores

Writes sweep_restitution.csv and sweep_restitution.svg (drawn by matplotlib when it is
installed, else by the few lines at the end of this file).
"""

import argparse
import csv
from pathlib import Path

import rigid_sandbox as rs

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "spawners.ron"
RESTITUTION = "spawners[1].actor.restitution"
ROCKS = "spawners[1].count"
GRID = {ROCKS: [27, 125, 343], RESTITUTION: [0.0, 0.3, 0.6, 0.9]}


def main():
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--backend", choices=["ray", "local"], default="ray")
    args.add_argument("--steps", type=int, default=500, help="steps per run (default 500: 5 s)")
    args.add_argument("--out", type=Path, default=Path("."), help="folder for the CSV and the plot")
    a = args.parse_args()
    results = rs.sweep(SCENE, GRID, steps=a.steps, backend=a.backend)
    rows = []
    for r in results:
        start = rs.Sim.from_file(SCENE, set=r["set"]).state()["totals"]["kinetic_energy"]
        end = r["state"]["totals"]["kinetic_energy"]
        rows.append({"rocks": r["set"][ROCKS], "restitution": r["set"][RESTITUTION], "kinetic_energy_start": start,
                     "kinetic_energy_end": end, "kept": end / start, "state_hash": r["state"]["state_hash"]})
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "sweep_restitution.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = {n: [(r["restitution"], r["kept"]) for r in rows if r["rocks"] == n] for n in GRID[ROCKS]}
    plot(lines, a.out / "sweep_restitution.svg", f"kinetic energy kept after {a.steps} steps")
    for n, points in lines.items():
        print(f"{n:4} rocks: " + ", ".join(f"e={e:.1f} keeps {k:.3f}" for e, k in points))
    print(f"wrote {a.out / 'sweep_restitution.csv'} and {a.out / 'sweep_restitution.svg'}")


def plot(lines, path, title):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return plain_svg(lines, path, title)
    fig, ax = plt.subplots(figsize=(6, 4))
    for n, points in lines.items():
        ax.plot(*zip(*points), marker="o", label=f"{n} rocks")
    ax.set(xlabel="rocks' restitution", ylabel="fraction of kinetic energy kept", title=title)
    ax.legend()
    fig.savefig(path)


def plain_svg(lines, path, title, width=480, height=320, margin=50):
    """A line chart without matplotlib: x and y from 0 to their largest value."""
    xmax = max(x for pts in lines.values() for x, _ in pts) or 1.0
    ymax = max(y for pts in lines.values() for _, y in pts) or 1.0

    def at(x, y):
        return margin + x / xmax * (width - 2 * margin), height - margin - y / ymax * (height - 2 * margin)

    colours = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728"]
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-size="12">',
             f'<text x="{width / 2}" y="20" text-anchor="middle">{title}</text>',
             f'<path d="M{margin},{margin}V{height - margin}H{width - margin}" stroke="black" fill="none"/>',
             f'<text x="{width / 2}" y="{height - 10}" text-anchor="middle">restitution (0 to {xmax:g})</text>',
             f'<text x="12" y="{margin - 10}">kept (0 to {ymax:.3g})</text>']
    for k, (n, points) in enumerate(lines.items()):
        colour = colours[k % len(colours)]
        d = " ".join(f"{'M' if i == 0 else 'L'}{x:.1f},{y:.1f}" for i, (x, y) in enumerate(at(*p) for p in points))
        parts.append(f'<path d="{d}" stroke="{colour}" fill="none" stroke-width="2"/>')
        parts.append(f'<text x="{width - margin + 5}" y="{at(*points[-1])[1]:.1f}" fill="{colour}">{n}</text>')
    Path(path).write_text("\n".join(parts + ["</svg>"]) + "\n")


if __name__ == "__main__":
    main()
