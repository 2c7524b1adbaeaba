#!/usr/bin/env python3
"""Writes the grasp-generation test library: non-convex objects as OBJ meshes of convex parts.

    make_mesh_library.py OUT_DIR [--only UID ...] [--project] [--list]

OUT_DIR/<uid>/<uid>.xml (one free body, one mesh geom per convex part, each colliding),
OUT_DIR/<uid>/<uid>.json (metadata as examples/custom_assets/asset_library/red_block/) and
OUT_DIR/<uid>/<uid>_part_NN.obj (closed, outward counter-clockwise triangles). Every object's
body frame has z up with the object's lowest point at z = 0 and its footprint centred on the
origin, so a scene places it on a floor at height 0.

--project makes OUT_DIR a pick project instead: the library in OUT_DIR/library, one scene per
object in OUT_DIR/scenes/scene_<uid>.xml (+ scene_<uid>_metadata.json: the object 0.45 m in
front of the robot, on the floor) and OUT_DIR/datagen.yaml (franka_droid, no cameras, every
attempt counted, the `block_pickup` sampler with the object's yaw drawn over +-180 deg), whose
grasp library is the same folder, so only grasps written there are used. Index the library
(`mlspaces index-assets OUT_DIR/library --compute-metadata`) and generate grasps
(`mlspaces generate-grasps OUT_DIR/library`) before `mlspaces datagen OUT_DIR/datagen.yaml`.

numpy only, no randomness: the same arguments write the same bytes.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class Obj:
    uid: str
    category: str
    description: str
    density: float  # kg/m^3
    friction: float
    parts: list[np.ndarray] = field(default_factory=list)  # each (2n, 3): bottom ring, top ring


# ---------------------------------------------------------------- convex parts (prisms)

def prism(bottom: np.ndarray, top: np.ndarray) -> np.ndarray:
    """A convex part from two rings of n points, each counter-clockwise seen from +z, the top
    ring above the bottom one (top[i] joined to bottom[i])."""
    return np.vstack([np.asarray(bottom, float), np.asarray(top, float)])


def box_part(lo, hi) -> np.ndarray:
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    ring = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    return prism(np.c_[ring, np.full(4, z0)], np.c_[ring, np.full(4, z1)])


def ngon(radius: float, n: int, z: float, phase: float = 0.0) -> np.ndarray:
    a = phase + 2 * np.pi * np.arange(n) / n
    return np.c_[radius * np.cos(a), radius * np.sin(a), np.full(n, z)]


def cylinder_part(radius: float, z0: float, z1: float, n: int = 24) -> np.ndarray:
    return prism(ngon(radius, n, z0), ngon(radius, n, z1))


def wall_segment(a0: float, a1: float, r_in0: float, r_in1: float, thick: float, z0: float,
                 z1: float) -> np.ndarray:
    """One segment of a (possibly flaring) wall between angles a0 < a1: inner radius r_in0 at
    z0 and r_in1 at z1, `thick` thick radially; chords, so adjacent segments share faces."""
    def ring(r_in, z):
        c0, s0, c1, s1 = np.cos(a0), np.sin(a0), np.cos(a1), np.sin(a1)
        r_out = r_in + thick
        return np.array([[r_in * c0, r_in * s0, z], [r_out * c0, r_out * s0, z],
                         [r_out * c1, r_out * s1, z], [r_in * c1, r_in * s1, z]])
    return prism(ring(r_in0, z0), ring(r_in1, z1))


def faces_of(part: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles (0-based) of a prism part, counter-clockwise seen from outside."""
    n = len(part) // 2
    out = []
    for i in range(1, n - 1):
        out.append((0, i + 1, i))              # bottom, facing -z
        out.append((n, n + i, n + i + 1))      # top, facing +z
    for i in range(n):
        j = (i + 1) % n
        out.append((i, j, n + j))
        out.append((i, n + j, n + i))
    return out


def check_part(part: np.ndarray, faces, where: str) -> None:
    """Every face non-degenerate and facing away from the centroid; volume positive."""
    c = part.mean(axis=0)
    vol = 0.0
    for f in faces:
        a, b, d = part[f[0]], part[f[1]], part[f[2]]
        nrm = np.cross(b - a, d - a)
        if np.linalg.norm(nrm) < 1e-12:
            raise ValueError(f"{where}: degenerate face {f}")
        if np.dot(nrm, (a + b + d) / 3 - c) <= 0:
            raise ValueError(f"{where}: face {f} faces inward")
        vol += np.dot(a, np.cross(b, d)) / 6
    if vol <= 0:
        raise ValueError(f"{where}: volume {vol} is not positive")


def obj_text(part: np.ndarray) -> str:
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in part]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces_of(part)]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------- objects

def mug(uid: str, radius: float, height: float, wall: float, base: float, segments: int,
        handle_reach: float, handle_height: float, handle_width: float,
        handle_bar: float) -> Obj:
    """A mug: `segments` straight wall segments, a base disc and a C handle of three bars on
    +x (top arm, grip, bottom arm), leaving a finger-wide gap between handle and wall."""
    o = Obj(uid, "mug", f"A ceramic mug, {2 * radius * 100:.0f} cm across.", 2000.0, 0.9)
    r_in = radius - wall
    phase = np.pi / segments  # a segment (not a seam) faces +x, where the handle attaches
    for k in range(segments):
        a0 = phase + 2 * np.pi * k / segments
        o.parts.append(wall_segment(a0, a0 + 2 * np.pi / segments, r_in, r_in, wall, 0.0, height))
    o.parts.append(prism(ngon(r_in + 1e-4, segments, 0.0, phase),
                         ngon(r_in + 1e-4, segments, base, phase)))
    x_wall = radius * np.cos(np.pi / segments) - 0.002   # inside the wall's outer face
    x_out = radius + handle_reach
    zc, hw = 0.55 * height, handle_width / 2
    z_lo, z_hi = zc - handle_height / 2, zc + handle_height / 2
    o.parts.append(box_part((x_wall, -hw, z_hi - handle_bar), (x_out, hw, z_hi)))
    o.parts.append(box_part((x_out - handle_bar, -hw, z_lo), (x_out, hw, z_hi)))
    o.parts.append(box_part((x_wall, -hw, z_lo), (x_out, hw, z_lo + handle_bar)))
    return o


def bowl(uid: str, r_bottom: float, r_top: float, height: float, wall: float, base: float,
         segments: int) -> Obj:
    """A flaring bowl: `segments` wall segments from inner radius r_bottom at z=0 to r_top at
    the rim, and a base disc."""
    o = Obj(uid, "bowl", f"A ceramic bowl, {2 * (r_top + wall) * 100:.0f} cm across.", 2000.0,
            0.9)
    for k in range(segments):
        a0 = 2 * np.pi * k / segments
        o.parts.append(wall_segment(a0, a0 + 2 * np.pi / segments, r_bottom, r_top, wall, 0.0,
                                    height))
    o.parts.append(prism(ngon(r_bottom + 1e-4, segments, 0.0), ngon(r_bottom + 1e-4, segments,
                                                                      base)))
    return o


def bracket(uid: str, leg: float, thick: float, width: float) -> Obj:
    """An L-bracket standing on one leg: a foot along x and an upright at the -x end."""
    o = Obj(uid, "bracket", f"An L-shaped bracket with {leg * 100:.0f} cm legs.", 1500.0, 0.8)
    x0, hw = -leg / 2, width / 2
    o.parts.append(box_part((x0, -hw, 0.0), (x0 + leg, hw, thick)))
    o.parts.append(box_part((x0, -hw, thick), (x0 + thick, hw, leg)))
    return o


def cylinder(uid: str, radius: float, height: float) -> Obj:
    o = Obj(uid, "cylinder", f"A wooden cylinder, {2 * radius * 100:.0f} cm across.", 700.0,
            0.8)
    o.parts.append(cylinder_part(radius, 0.0, height))
    return o


def box(uid: str, sx: float, sy: float, sz: float) -> Obj:
    o = Obj(uid, "box", f"A {sx * 100:.0f} x {sy * 100:.0f} x {sz * 100:.0f} cm box.", 500.0,
            0.8)
    o.parts.append(box_part((-sx / 2, -sy / 2, 0.0), (sx / 2, sy / 2, sz)))
    return o


def library() -> list[Obj]:
    """The objects, smallest first within a kind. The gripper's pads open to 85 mm."""
    return [
        mug("mug_small", 0.036, 0.085, 0.006, 0.008, 6, 0.030, 0.050, 0.014, 0.010),
        mug("mug_large", 0.045, 0.100, 0.007, 0.009, 6, 0.035, 0.060, 0.016, 0.011),
        bowl("bowl_small", 0.035, 0.055, 0.045, 0.005, 0.006, 12),
        bowl("bowl_large", 0.045, 0.075, 0.060, 0.006, 0.007, 12),
        bracket("bracket_small", 0.060, 0.015, 0.040),
        bracket("bracket_large", 0.090, 0.020, 0.050),
        cylinder("cylinder_thin", 0.020, 0.100),
        cylinder("cylinder_medium", 0.030, 0.120),
        cylinder("cylinder_short", 0.035, 0.050),
        box("box_small", 0.040, 0.040, 0.040),
        box("box_tall", 0.050, 0.060, 0.120),
        box("box_flat", 0.060, 0.100, 0.040),
    ]


# ---------------------------------------------------------------- files

def asset_xml(o: Obj) -> str:
    meshes = "\n".join(f'    <mesh name="{o.uid}_part_{k:02d}" file="{o.uid}_part_{k:02d}.obj"/>'
                       for k in range(len(o.parts)))
    geoms = "\n".join(
        f'      <geom name="{o.uid}_part_{k:02d}" type="mesh" mesh="{o.uid}_part_{k:02d}" '
        f'density="{o.density:g}" friction="{o.friction:g} 0.005 0.0001" rgba="0.8 0.6 0.4 1"/>'
        for k in range(len(o.parts)))
    return (f'<mujoco model="{o.uid}">\n  <asset>\n{meshes}\n  </asset>\n  <worldbody>\n'
            f'    <body name="{o.uid}">\n      <freejoint/>\n{geoms}\n    </body>\n'
            f'  </worldbody>\n</mujoco>\n')


def asset_json(o: Obj) -> str:
    meta = {
        "assetId": o.uid,
        "category": o.category,
        "description_long": o.description + " Written by bench/graspgen/make_mesh_library.py.",
        "description": o.description,
        "description_short": {"one_word": o.category, "two_words": f"test {o.category}",
                              "three_words": f"generated test {o.category}"},
        "synset": f"{o.category}.n.01",
    }
    return json.dumps(meta, indent=4) + "\n"


def write_object(o: Obj, out: Path) -> None:
    d = out / o.uid
    d.mkdir(parents=True, exist_ok=True)
    lo = np.min([p.min(axis=0) for p in o.parts], axis=0)
    hi = np.max([p.max(axis=0) for p in o.parts], axis=0)
    shift = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    for k, part in enumerate(o.parts):
        part = part + shift
        check_part(part, faces_of(part), f"{o.uid} part {k}")
        (d / f"{o.uid}_part_{k:02d}.obj").write_text(obj_text(part))
    (d / f"{o.uid}.xml").write_text(asset_xml(o))
    (d / f"{o.uid}.json").write_text(asset_json(o))


# The scene's <option> rules the robot's (attach drops the robot file's): elliptic cones and
# impratio 10 as MuJoCo Menagerie's 2F-85 asks for, and multi-contact CCD so a flat pad on a
# flat mesh face touches in several points, not one. With MuJoCo's defaults (pyramidal cone,
# impratio 1, one contact per mesh pair) even a centred grasp of the 4 cm mesh cube slips out
# of the 2F-85 (docs/graspgen.md "Benchmarks").
SCENE = """<mujoco model="graspgen_pick_{uid}">
  <option integrator="implicit" timestep="0.002" cone="elliptic" impratio="10">
    <flag multiccd="enable"/>
  </option>
  <asset>
    <model name="{uid}_model" file="../library/{uid}/{uid}.xml"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" pos="0 0 0"/>
    <light name="key_light" pos="1 -1 2" dir="-0.5 0.5 -1" directional="true"/>
    <frame pos="0.45 0 0.0005">
      <attach model="{uid}_model" prefix=""/>
    </frame>
  </worldbody>
</mujoco>
"""

CONFIG = """# Generated by bench/graspgen/make_mesh_library.py --project: pick every object of the
# generated mesh library with only the grasps generate-grasps wrote into it. One scene per
# object (one work item each), franka_droid on the floor, no cameras, every attempt counted.
#
#   mlspaces index-assets library --compute-metadata --overwrite
#   mlspaces generate-grasps library --max-grasps 200
#   mlspaces datagen datagen.yaml --episodes 9 --seed 1 --output runs/seed_1
libraries:
  asset_libraries:
    - {{name: graspgen_meshes, path: library}}
  grasp_libraries:
    - {{name: graspgen_meshes_grasps, path: library, asset_library: graspgen_meshes}}

scene_dataset: user
num_workers: 1
output_dir: experiment_output
tag: graspgen_mesh_pick
filter_for_successful_trajectories: false

robot_config:
  name: franka_droid
  base_size: null

task_config:
  enable_rendering: false

task_sampler_config:
  task_sampler_class: block_pickup
  dataset_name: user
  scene_xml_paths: [{scenes}]
  samples_per_house: 9
  robot_base_noise: {{x: 0.1, y: 0.1, yaw_deg: 30}}
  object_noise: {{x: 0.05, y: 0.05, yaw_deg: 180}}
  goal_offset_z: 0.05
"""


def write_project(objs: list[Obj], out: Path) -> None:
    scenes = out / "scenes"
    scenes.mkdir(parents=True, exist_ok=True)
    for o in objs:
        (scenes / f"scene_{o.uid}.xml").write_text(SCENE.format(uid=o.uid))
        meta = {"objects": {o.uid: {"asset_id": o.uid, "object_id": o.uid,
                                    "category": o.category, "is_static": False}}}
        (scenes / f"scene_{o.uid}_metadata.json").write_text(json.dumps(meta, indent=4) + "\n")
    names = ", ".join(f"scenes/scene_{o.uid}.xml" for o in objs)
    (out / "datagen.yaml").write_text(CONFIG.format(scenes=names))


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path, help="output folder (created)")
    ap.add_argument("--only", nargs="+", metavar="UID", help="write only these objects")
    ap.add_argument("--project", action="store_true",
                    help="write a pick project: library/, scenes/, datagen.yaml")
    ap.add_argument("--list", action="store_true", help="print the objects and their parts")
    args = ap.parse_args(argv)
    objs = library()
    if args.only:
        known = {o.uid for o in objs}
        bad = [u for u in args.only if u not in known]
        if bad:
            print(f"make_mesh_library: unknown uid {', '.join(bad)} (known: "
                  f"{', '.join(sorted(known))})", file=sys.stderr)
            return 2
        objs = [o for o in objs if o.uid in args.only]
    lib = args.out / "library" if args.project else args.out
    for o in objs:
        write_object(o, lib)
        if args.list:
            print(f"{o.uid}: {len(o.parts)} convex parts")
    if args.project:
        write_project(objs, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
