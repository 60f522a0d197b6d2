"""Tests of the Python module sparse_mpm (python/sparse_mpm.cpp), run by CTest with the build directory on
PYTHONPATH: frames read into numpy arrays, a scene advanced frame by frame with its particles at hand, and
`run` writing the frames `mpm run` writes."""
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import sparse_mpm

FREE_BALL = {
    "simulation": {"frames": 4, "dx": 0.05, "substeps": 2, "gravity": [0, 0, 0]},
    "output": {"surface": False, "attributes": ["J", "Jp", "stress_norm", "F", "plastic_strain"]},
    "sets": [{"name": "ball", "material": "jelly", "shape": {"type": "sphere", "center": [0, 0, 0], "radius": 0.2}},
             {"name": "drop", "material": "water", "shape": {"type": "box", "min": [1, 0, 0], "max": [1.2, 0.2, 0.2]}}],
}


def scene_file(directory, name, scene):
    path = os.path.join(directory, name)
    with open(path, "w") as f:
        json.dump(scene, f)
    return path


class SimulationTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="sparse_mpm_py_")
        self.scene = scene_file(self.dir, "free.json", FREE_BALL)

    def test_particles_are_numpy_arrays_with_every_attribute(self):
        sim = sparse_mpm.Simulation(self.scene, threads=2)
        p = sim.particles()
        n = len(p["id"])
        self.assertGreater(n, 500)
        self.assertEqual(p["P"].dtype, np.float64)
        self.assertEqual(p["P"].shape, (n, 3))
        self.assertEqual(p["v"].dtype, np.float32)
        self.assertEqual(p["F"].shape, (n, 3, 3))
        for key in ("id", "material", "set", "pscale", "Cd", "J", "Jp", "stress_norm", "plastic_strain", "density",
                    "youngs_modulus", "poisson_ratio", "bulk_modulus", "viscosity", "yield_stress"):
            self.assertEqual(len(p[key]), n, key)
        # At rest: F = I, J = 1, no stress; ids 0..n-1; the sets' names.
        np.testing.assert_allclose(p["F"], np.broadcast_to(np.eye(3, dtype=np.float32), (n, 3, 3)))
        np.testing.assert_array_equal(np.sort(p["id"]), np.arange(n))
        self.assertEqual(sim.set_names, ["ball", "drop"])
        self.assertEqual(float(np.abs(p["stress_norm"]).max()), 0.0)
        self.assertEqual(float(np.abs(p["plastic_strain"]).max()), 0.0)
        # The sets' parameters: jelly's defaults (400 kg/m^3, E 1.4e5 Pa back from its float Lame parameters), water's
        # 1000 kg/m^3 and no Young's modulus.
        ball, drop = p["set"] == 0, p["set"] == 1
        np.testing.assert_allclose(p["density"][ball], 400.0, rtol=1e-6)
        np.testing.assert_allclose(p["youngs_modulus"][ball], 1.4e5, rtol=1e-5)
        np.testing.assert_allclose(p["density"][drop], 1000.0, rtol=1e-6)
        np.testing.assert_array_equal(p["youngs_modulus"][drop], 0.0)

    def test_a_velocity_set_from_python_carries_the_bodies_as_momentum_says(self):
        # No gravity, no collider: bodies given one velocity move rigidly by v t, and momentum is M v throughout.
        sim = sparse_mpm.Simulation(self.scene, threads=2)
        before = sim.particles()
        start = before["P"][np.argsort(before["id"])]  # the engine reorders particles by leaf: compare by id
        n = len(start)
        v = np.tile(np.array([1.0, 0.5, 0.0], dtype=np.float32), (n, 1))
        sim.set_velocities(v)
        mass = sim.stats()["mass"]
        np.testing.assert_allclose(sim.stats()["momentum"], [mass * 1.0, mass * 0.5, 0.0], rtol=1e-6, atol=1e-9)
        stats = sim.advance(3)
        self.assertEqual(sim.frame, 3)
        self.assertAlmostEqual(sim.time, 3 / 24.0, places=12)
        np.testing.assert_allclose(stats["momentum"], [mass * 1.0, mass * 0.5, 0.0], rtol=1e-5, atol=1e-7)
        after = sim.particles()
        moved = after["P"][np.argsort(after["id"])] - start
        np.testing.assert_allclose(moved, np.tile([1.0 * sim.time, 0.5 * sim.time, 0.0], (n, 1)), atol=1e-5)
        with self.assertRaises(ValueError):
            sim.set_velocities(np.zeros((n + 1, 3), dtype=np.float32))

    def test_run_writes_frames_that_read_back_as_the_state(self):
        out = os.path.join(self.dir, "out")
        self.assertEqual(sparse_mpm.run(self.scene, out, threads=2), out)
        files = sorted(f for f in os.listdir(out) if f.startswith("free_") and f.endswith(".vdb"))
        self.assertEqual(files, ["free_%04d.vdb" % f for f in range(1, 5)])  # frames 1..4, no initial state
        frame = sparse_mpm.read_frame(os.path.join(out, "free_0004.vdb"))
        sim = sparse_mpm.Simulation(self.scene, threads=1)
        sim.advance(4)
        state = sim.particles()
        order = np.argsort(frame["id"])
        by_id = np.argsort(state["id"])
        # The same run (any thread count gives the same bits); P within the 16-bit fixed point of a voxel.
        np.testing.assert_array_equal(frame["id"][order], state["id"][by_id])
        self.assertLess(np.abs(frame["P"][order] - state["P"][by_id]).max(), 0.05 / 65536 * 2 + 1e-9)
        np.testing.assert_array_equal(frame["v"][order], state["v"][by_id])
        np.testing.assert_array_equal(frame["F"][order], state["F"][by_id])
        names = sparse_mpm.read_frame_names(os.path.join(out, "free_0004.vdb"))
        self.assertEqual(names["set_names"], ["ball", "drop"])
        self.assertEqual(names["groups"]["material_jelly"], "jelly")
        np.testing.assert_array_equal(names["group_members"]["set_drop"], frame["set"] == 1)
        np.testing.assert_array_equal(names["group_members"]["material_water"],
                                      frame["material"] == names["material_names"].index("water"))

    def test_stats_say_what_set_the_step_and_plot(self):
        # A stiff jelly at rest, no gravity: the CFL bound from its wave speed sets every step, and a frame of
        # 1/24 s takes as many substeps as that bound fits.
        out = os.path.join(self.dir, "plotted")
        sparse_mpm.run(self.scene, out, threads=2)
        with open(os.path.join(out, "stats.csv"), newline="") as f:
            rows = [r for r in csv.DictReader(f) if int(r["frame"]) > 0]
        self.assertEqual(len(rows), 4)
        for r in rows:
            self.assertEqual(r["step_limit"], "cfl_wave_speed ball")
            fits = (1 / 24.0) / float(r["step_dt"])
            self.assertEqual(int(r["substeps"]), math.ceil(fits - 1e-9), r)
        tool = os.path.join(os.path.dirname(__file__), "..", "tools", "plot_stats.py")
        done = subprocess.run([sys.executable, tool, out], capture_output=True, text=True)
        self.assertEqual(done.returncode, 0, done.stderr)
        import matplotlib.image
        for name in ("energy", "momentum", "particles", "substeps"):
            image = matplotlib.image.imread(os.path.join(out, name + ".png"))
            self.assertGreaterEqual(image.shape[0], 400, name)
            self.assertGreater(float(image[..., :3].std()), 0.01, name)  # something is drawn
        nowhere = subprocess.run([sys.executable, tool, self.dir + "/none"], capture_output=True, text=True)
        self.assertEqual(nowhere.returncode, 2)
        self.assertIn("no stats.csv", nowhere.stderr)

    def test_an_outside_solver_driving_the_bodies_gets_the_built_in_result(self):
        # A spinning ball thrown into a pool. Its dynamics written in Python from what set_body_driver hands over
        # (symplectic Euler: v += dt g + J / m, I w += L, the pose moved by the module) must give what the built-in
        # solver gives; the velocity update is the same arithmetic, the spin's solve is not, so round-off differs
        # (measured: centre and velocity the same bits after 6 frames, spin 2e-14 rad/s apart; 1e-9 allowed).
        scene = scene_file(self.dir, "ball.json", {
            "simulation": {"frames": 6, "dx": 0.02},
            "output": {"surface": False},
            "sets": [{"name": "pool", "material": "water", "shape": {"type": "box", "min": [0, 0, 0], "max": [0.3, 0.4, 0.2]}}],
            "colliders": [{"type": "plane"},
                          {"type": "sphere", "center": [0.13, 0.46, 0.1], "radius": 0.04,
                           "dynamic": {"density": 2000, "velocity": [0.2, -0.5, 0], "angular_velocity": [0, 0, 3]}}]})
        built = sparse_mpm.Simulation(scene, threads=2)
        built.advance(6)
        outside = sparse_mpm.Simulation(scene, threads=2)
        body = outside.bodies()[0]
        self.assertEqual(body["collider"], 1)
        self.assertAlmostEqual(body["mass"], 2000 * 4 / 3 * math.pi * 0.04 ** 3, places=12)
        g = np.array([0.0, -9.81, 0.0])
        calls, pushed = [0], [np.zeros(3)]

        def solve(k, dt, impulse, angular_impulse, state):
            calls[0] += 1
            pushed[0] = pushed[0] + np.array(impulse)
            I = np.array(outside.bodies()[k]["inertia"])
            v = (np.array(state["velocity"]) + dt * g) + np.array(impulse) / body["mass"]
            w = np.linalg.solve(I, I @ np.array(state["spin"]) + np.array(angular_impulse))
            return {"velocity": v.tolist(), "spin": w.tolist()}

        outside.set_body_driver(solve)
        substeps = sum(outside.advance(1)["substeps"] for _ in range(6))
        self.assertEqual(calls[0], substeps)  # once a substep for the one body
        a, b = built.bodies()[0], outside.bodies()[0]
        for key in ("centre", "velocity", "spin"):
            np.testing.assert_allclose(b[key], a[key], rtol=0, atol=1e-9, err_msg=key)
        self.assertLess(a["centre"][1], 0.4)  # it went into the water (not down to the floor: no contact here)...
        self.assertGreater(pushed[0][1], 0.0)  # ...which pushed it up
        # None restores the built-in solver: both go on alike.
        outside.set_body_driver(None)
        built.advance(1)
        outside.advance(1)
        np.testing.assert_allclose(outside.bodies()[0]["centre"], built.bodies()[0]["centre"], rtol=0, atol=1e-9)

    def test_a_body_drivers_mistakes_are_named_errors(self):
        scene = scene_file(self.dir, "drop.json", {
            "simulation": {"frames": 2, "dx": 0.04},
            "sets": [{"material": "water", "shape": {"type": "box", "min": [0, 0, 0], "max": [0.2, 0.1, 0.2]}}],
            "colliders": [{"type": "plane"}, {"type": "sphere", "center": [0.1, 0.3, 0.1], "radius": 0.04,
                                               "dynamic": {"density": 800}}]})
        with self.assertRaises(TypeError) as caught:
            sparse_mpm.Simulation(scene).set_body_driver(42)
        self.assertIn("expected a function", str(caught.exception))
        cases = [(lambda *a: {"velocty": [0, 0, 0]}, ValueError, 'unknown key "velocty"'),
                 (lambda *a: [1, 2, 3], TypeError, "return a dict"),
                 (lambda *a: {"velocity": "abc"}, TypeError, "velocity must be 3 numbers"),
                 (lambda *a: {"velocity": [0, 1]}, ValueError, "velocity must be 3 numbers"),
                 (lambda *a: {"spin": [0, float("nan"), 0]}, ValueError, "spin holds a value that is not finite"),
                 (lambda *a: {"orientation": [0, 0, 0, 0]}, ValueError, "orientation must be a nonzero quaternion")]
        for fn, kind, said in cases:
            sim = sparse_mpm.Simulation(scene)
            sim.set_body_driver(fn)
            with self.assertRaises(kind) as caught:
                sim.advance(1)
            self.assertIn("body driver (body 0): " + said, str(caught.exception))

    def test_read_bodies_gives_the_poses_of_bodies_csv(self):
        scene = scene_file(self.dir, "spin.json", {
            "simulation": {"frames": 2, "dx": 0.04},
            "sets": [{"material": "water", "shape": {"type": "box", "min": [0, 0, 0], "max": [0.2, 0.1, 0.2]}}],
            "colliders": [{"type": "plane"}, {"type": "box", "center": [0.1, 0.5, 0.1], "size": [0.1, 0.05, 0.1],
                                               "dynamic": {"density": 600, "angular_velocity": [0, 3, 0]}}]})
        out = sparse_mpm.run(scene, os.path.join(self.dir, "spin_out"), threads=2)
        b = sparse_mpm.read_bodies(os.path.join(out, "spin_0002.vdb"))
        with open(os.path.join(out, "bodies.csv")) as f:
            row = [r for r in csv.DictReader(f) if r["frame"] == "2"][0]
        self.assertEqual(b["collider"].tolist(), [1])
        self.assertEqual(b["name"], ["collider1"])
        self.assertEqual(row["name"], "collider1")
        np.testing.assert_allclose(b["P"][0], [float(row[k]) for k in "xyz"], atol=1e-6)
        np.testing.assert_allclose(b["orient"][0], [float(row[k]) for k in ("qx", "qy", "qz", "qw")], atol=1e-6)
        np.testing.assert_allclose(b["w"][0], [float(row[k]) for k in ("wx", "wy", "wz")], atol=1e-6)
        # Free flight about y at 3 rad/s: the turn is 3 t about y.
        self.assertAlmostEqual(2 * math.atan2(b["orient"][0][1], b["orient"][0][3]), 3 * 2 / 24, places=5)
        self.assertEqual(len(sparse_mpm.read_bodies(os.path.join(out, "spin_0001.vdb"))["collider"]), 1)

    def test_the_render_tools_material_colours_are_the_engines(self):
        # tools/render_blender.py runs in Blender's own Python, which cannot load this module: it keeps a copy of
        # the materials' colours (kColour) for surfaces of sets of several colours, checked here.
        import ast
        path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "render_blender.py")
        tree = ast.parse(open(path).read())
        copy = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                    and any(getattr(t, "id", "") == "MATERIAL_COLOURS" for t in n.targets))
        engine = sparse_mpm.material_colours()
        self.assertEqual(set(copy), set(engine))
        for name, rgb in engine.items():
            np.testing.assert_allclose(copy[name], rgb, atol=1e-6, err_msg=name)

    def test_a_bad_scene_is_a_named_error(self):
        bad = scene_file(self.dir, "bad.json", {"sets": [{"material": "wter"}]})
        with self.assertRaises(ValueError) as caught:
            sparse_mpm.Simulation(bad)
        self.assertIn("bad.json: /sets/0/material: unknown material \"wter\"", str(caught.exception))
        with self.assertRaises(Exception):
            sparse_mpm.read_frame(os.path.join(self.dir, "missing.vdb"))


if __name__ == "__main__":
    unittest.main(verbosity=2)
