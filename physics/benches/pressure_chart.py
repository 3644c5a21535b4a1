#!/usr/bin/env python3
"""Log-log chart of pressure-solve time against unknowns from the output of
`cargo bench -p multifield-physics --bench pressure` (no dependencies: writes SVG).

    cargo bench -p multifield-physics --bench pressure 2>&1 | tee bench.txt
    python3 physics/benches/pressure_chart.py bench.txt docs/img/pressure_scaling.svg
"""
import math
import re
import sys

UNIT = {"ns": 1e-6, "µs": 1e-3, "us": 1e-3, "ms": 1.0, "s": 1e3}


def parse(path):
    """{(rho, threads, solver): {n: median ms}} and {(solver, rho, n): iterations}."""
    times, its, current = {}, {}, None
    for line in open(path, encoding="utf-8"):
        m = re.match(r"^pressure/rho([\d.]+)/threads(\d+)/(\w+)/(\d+)\s*$", line)
        if m:
            current = (m.group(1), int(m.group(2)), m.group(3), int(m.group(4)))
            continue
        m = re.search(r"time:\s+\[\S+ \S+ (\S+) (\S+) \S+ \S+\]", line)
        if m and current:
            rho, threads, solver, n = current
            times.setdefault((rho, threads, solver), {})[n] = float(m.group(1)) * UNIT[m.group(2)]
            current = None
        m = re.match(r"^iterations (\w+) ([\d.]+) (\d+) (\d+)", line)
        if m:
            its[(m.group(1), m.group(2), int(m.group(3)))] = int(m.group(4))
    return times, its


def chart(times, rho, out):
    w, h, left, right, top, bottom = 720, 480, 70, 170, 40, 50
    series = {k: v for k, v in times.items() if k[0] == rho}
    xs = [n * n for v in series.values() for n in v]
    ys = [t for v in series.values() for t in v.values()]
    x0, x1 = math.log10(min(xs)) - 0.1, math.log10(max(xs)) + 0.1
    y0, y1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
    px = lambda x: left + (math.log10(x) - x0) / (x1 - x0) * (w - left - right)
    py = lambda y: h - bottom - (math.log10(y) - y0) / (y1 - y0) * (h - top - bottom)
    colors = {"mg_pcg": "#1f77b4", "mg_pcg_before": "#9ecae1", "multigrid": "#2ca02c", "cholesky": "#d62728", "jacobi_pcg": "#7f7f7f"}
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<text x="{w / 2 - 60}" y="20" font-size="14">Pressure solve time, ρ disk = {rho}, tol 1e-8</text>']
    for e in range(y0, y1 + 1):
        y = py(10 ** e)
        svg.append(f'<line x1="{left}" x2="{w - right}" y1="{y}" y2="{y}" stroke="#ddd"/>')
        svg.append(f'<text x="{left - 8}" y="{y + 4}" text-anchor="end">1e{e} ms</text>')
    for n in sorted({n for v in series.values() for n in v}):
        x = px(n * n)
        svg.append(f'<line x1="{x}" x2="{x}" y1="{top}" y2="{h - bottom}" stroke="#eee"/>')
        svg.append(f'<text x="{x}" y="{h - bottom + 16}" text-anchor="middle">{n}²</text>')
    svg.append(f'<text x="{(w - right + left) / 2}" y="{h - 12}" text-anchor="middle">unknowns</text>')
    legend = 0
    for (rho_, threads, solver), pts in sorted(series.items(), key=lambda kv: (kv[0][2], kv[0][1])):
        pts = sorted(pts.items())
        dash = "" if threads == 1 else ' stroke-dasharray="5,3"'
        path = " ".join(f"{px(n * n):.1f},{py(t):.1f}" for n, t in pts)
        c = colors.get(solver, "black")
        svg.append(f'<polyline points="{path}" fill="none" stroke="{c}" stroke-width="2"{dash}/>')
        for n, t in pts:
            svg.append(f'<circle cx="{px(n * n):.1f}" cy="{py(t):.1f}" r="3" fill="{c}"/>')
        ly = top + 10 + 18 * legend
        svg.append(f'<line x1="{w - right + 10}" x2="{w - right + 35}" y1="{ly}" y2="{ly}" stroke="{c}" stroke-width="2"{dash}/>')
        svg.append(f'<text x="{w - right + 40}" y="{ly + 4}">{solver}, {threads} thr</text>')
        legend += 1
    # reference slope: time ∝ unknowns
    n0 = min(xs)
    t0 = min(series.get((rho, 1, "mg_pcg"), {0: min(ys)}).values())
    svg.append(f'<line x1="{px(n0)}" y1="{py(t0 / 2)}" x2="{px(max(xs))}" y2="{py(t0 / 2 * max(xs) / n0)}" '
               'stroke="black" stroke-dasharray="2,4"/>')
    svg.append(f'<text x="{px(max(xs)) - 5}" y="{py(t0 / 2 * max(xs) / n0) + 16}" text-anchor="end">∝ unknowns</text>')
    svg.append("</svg>")
    open(out, "w", encoding="utf-8").write("\n".join(svg))


if __name__ == "__main__":
    times, its = parse(sys.argv[1])
    out = sys.argv[2]
    for rho in sorted({k[0] for k in times}):
        chart(times, rho, out.replace(".svg", f"_rho{rho}.svg"))
    for k in sorted(times):
        print(k, {n: round(t, 3) for n, t in sorted(times[k].items())})
    for k in sorted(its):
        print("iterations", k, its[k])
