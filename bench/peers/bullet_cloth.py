#!/usr/bin/env python3
"""Bullet's soft-body cloth timed on this host, for the demo's Table 2.

Builds the cloths of softbody's `step` benchmark in Bullet (pybullet from PyPI): an n x n grid
of 1 m side and 1 kg, triangulated with one diagonal per quad (the (i,j)-(i+1,j+1) one, as
`GridCloth::triangles`), loaded with `loadSoftBody` from an OBJ file, its four corners pinned
(`createSoftBodyAnchor` with no body: mass 0), gravity -9.81, dt 1/60, one `stepSimulation`
per step. It lets the cloth sag for 30 steps, then times each of the next steps and prints
the median and mean ms per step, and writes them (with the host's CPU) to a JSON results file
that `cargo run --release -p slod-demo` reads for Table 2.

What pybullet forces (pybullet 3.2.7, `PhysicsServerCommandProcessor::processLoadSoftBodyCommand`
in the soft-body world, i.e. without RESET_USE_DEFORMABLE_WORLD), so that the comparison
with slod's `bullet65`/`bullet129` benchmarks is like for like:
  * 20 position-solver iterations per step (`m_cfg.piterations = 20`), not settable from Python;
  * distance-2 bending links (`generateBendingConstraints(2)`), i.e. triangle edges + bend
    links: 12,416 + 24,319 links at 65 x 65, as slod's `GridCloth::build_bullet`;
  * link stiffness kLST = 0.5 (slod's bench uses compliance 0: as stiff as the iterations allow);
  * `randomizeConstraints()` (link order shuffled), friction kDF = 0.5, soft-soft collision
    flag on (there is only one body, no self-collision), a broadphase and collision pass
    every step (slod has no collision stage in this benchmark);
  * double precision: the PyPI wheel is built with BT_USE_DOUBLE_PRECISION (slod uses f32);
  * one thread (Bullet's soft-body solver here is single-threaded; so is slod's step bench).

Usage:
  python3 bench/peers/bullet_cloth.py                # 65 and 129, writes the results file
  python3 bench/peers/bullet_cloth.py --sizes 65 --steps 200 --out /tmp/bullet.json

It creates its own virtual environment (bench/peers/.venv) and installs pybullet into it the
first time, then re-runs itself inside it.
"""

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import venv

HERE = os.path.dirname(os.path.abspath(__file__))
VENV = os.path.join(HERE, ".venv")
PYBULLET = "pybullet==3.2.7"
# The wheel is built with numpy support and fails to import without numpy.
NUMPY = "numpy"
DEFAULT_OUT = os.path.join(HERE, "results", "bullet_cloth.json")


def venv_python():
    return os.path.join(VENV, "bin", "python3")


def ensure_venv():
    """Re-executes inside bench/peers/.venv with pybullet installed (created on first use)."""
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        return
    if not os.path.exists(venv_python()):
        print(f"creating {VENV} and installing {PYBULLET} ...", file=sys.stderr)
        venv.create(VENV, with_pip=True)
        subprocess.check_call([venv_python(), "-m", "pip", "install", "--quiet", PYBULLET, NUMPY])
    os.execv(venv_python(), [venv_python(), os.path.abspath(__file__)] + sys.argv[1:])


def write_grid_obj(path, n):
    """An n x n grid of side 1 m in the XZ plane, two triangles per quad."""
    s = 1.0 / (n - 1)
    with open(path, "w") as f:
        for j in range(n):
            for i in range(n):
                f.write(f"v {i * s:.9f} 0 {j * s:.9f}\n")
        for j in range(n - 1):
            for i in range(n - 1):
                a = j * n + i + 1  # OBJ indices start at 1
                b, c, d = a + 1, a + n + 1, a + n
                f.write(f"f {a} {b} {c}\n")
                f.write(f"f {a} {c} {d}\n")


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def time_cloth(p, n, sag_steps, steps):
    p.resetSimulation()
    p.setGravity(0, -9.81, 0)
    p.setTimeStep(1.0 / 60.0)
    with tempfile.TemporaryDirectory() as tmp:
        obj = os.path.join(tmp, f"grid{n}.obj")
        write_grid_obj(obj, n)
        cloth = p.loadSoftBody(obj, basePosition=[0, 0, 0], scale=1.0, mass=1.0,
                               useNeoHookean=0, useBendingSprings=1, useMassSpring=1,
                               useSelfCollision=0, collisionMargin=0.001)
    if cloth < 0:
        raise RuntimeError(f"loadSoftBody failed for {n}x{n}")
    count, verts = p.getMeshData(cloth, flags=p.MESH_DATA_SIMULATION_MESH)
    if count != n * n:
        raise RuntimeError(f"{n}x{n}: Bullet has {count} nodes, expected {n * n}")
    # Pin the nodes nearest to the four corners (Bullet keeps the OBJ's vertex order, but
    # finding them by position does not depend on it).
    corners = []
    for cx, cz in [(0, 0), (1, 0), (0, 1), (1, 1)]:
        k = min(range(count), key=lambda i: (verts[i][0] - cx) ** 2 + (verts[i][2] - cz) ** 2)
        p.createSoftBodyAnchor(cloth, k, -1, -1)
        corners.append(k)
    for _ in range(sag_steps):
        p.stepSimulation()
    times = []
    for _ in range(steps):
        t0 = time.perf_counter()
        p.stepSimulation()
        times.append((time.perf_counter() - t0) * 1e3)
    # Sanity: the corners held and the cloth sagged (it was simulated, not frozen).
    _, verts = p.getMeshData(cloth, flags=p.MESH_DATA_SIMULATION_MESH)
    if any(abs(verts[k][1]) > 1e-6 for k in corners):
        raise RuntimeError(f"{n}x{n}: a pinned corner moved")
    sag = -min(v[1] for v in verts)
    if not sag > 1e-3:
        raise RuntimeError(f"{n}x{n}: the cloth did not sag ({sag} m)")
    return {
        "size": n,
        "nodes": count,
        "iterations": 20,
        "steps": steps,
        "sag_m": sag,
        "median_ms_per_step": statistics.median(times),
        "mean_ms_per_step": statistics.fmean(times),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="65,129", help="comma-separated cloth sides (default 65,129)")
    ap.add_argument("--steps", type=int, default=0,
                    help="timed steps per cloth (default: 120 at 65, 30 at 129)")
    ap.add_argument("--out", default=DEFAULT_OUT, help=f"results file (default {DEFAULT_OUT})")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",") if s]
    if any(n < 2 for n in sizes):
        ap.error("every size must be at least 2")
    ensure_venv()
    import pybullet as p  # noqa: E402 (inside the venv now)

    p.connect(p.DIRECT)
    rows = []
    for n in sizes:
        steps = args.steps or (120 if n <= 65 else 30)
        r = time_cloth(p, n, 30, steps)
        rows.append(r)
        print(f"bullet {n}x{n}: {r['median_ms_per_step']:.2f} ms/step median, "
              f"{r['mean_ms_per_step']:.2f} mean ({steps} steps, 20 iterations)")
    p.disconnect()
    out = {
        "schema": "slod-peer-bullet/1",
        "engine": f"pybullet {p.getAPIVersion()} ({PYBULLET}), double precision",
        "cpu_model": cpu_model(),
        "measured_unix_s": int(time.time()),
        "cloths": rows,
    }
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(out, f, indent=2)
        f.write("\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
