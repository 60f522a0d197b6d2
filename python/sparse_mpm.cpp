// The Python module `sparse_mpm` (pybind11): frames read into numpy arrays without pyopenvdb (which cannot
// read VDB points), and scenes run whole or advanced frame by frame with the particles at hand, for sweeps
// and analysis. Built into the build directory as sparse_mpm*.so; docs in README ("From Python").
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/global_control.h>

#include <cmath>
#include <memory>
#include <optional>
#include <thread>

#include "io/Run.h"
#include "io/Scene.h"
#include "io/SceneKeys.h"
#include "io/VdbWriter.h"

namespace py = pybind11;
using namespace mpm;

namespace {

/// An (n, k...) numpy array of T filled from n items of `width` scalars each.
template <class T, class Item, class Get>
py::array_t<T> table(const std::vector<Item>& items, std::vector<py::ssize_t> shape, Get get) {
    shape.insert(shape.begin(), py::ssize_t(items.size()));
    py::array_t<T> a(shape);
    T* out = a.mutable_data();
    std::size_t width = 1;
    for (std::size_t d = 1; d < shape.size(); ++d) width *= std::size_t(shape[d]);
    for (std::size_t i = 0; i < items.size(); ++i) get(items[i], out + i * width);
    return a;
}

py::array_t<double> positions(const std::vector<Vec3d>& x) {
    return table<double>(x, {3}, [](const Vec3d& p, double* o) { o[0] = p[0], o[1] = p[1], o[2] = p[2]; });
}
py::array_t<float> vectors(const std::vector<Vec3f>& v) {
    return table<float>(v, {3}, [](const Vec3f& p, float* o) { o[0] = p[0], o[1] = p[1], o[2] = p[2]; });
}
py::array_t<float> matrices(const std::vector<Mat3f>& F) {
    return table<float>(F, {3, 3}, [](const Mat3f& m, float* o) {
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) o[3 * r + c] = m(r, c);
    });
}
template <class T>
py::array_t<T> scalars(const std::vector<T>& s) {
    return py::array_t<T>(py::ssize_t(s.size()), s.data());
}

/// The dict of a frame's point attributes: every array the points have, keyed by its attribute name.
template <class Points>
py::dict pointDict(const Points& p) {
    py::dict d;
    d["P"] = positions(p.x);
    d["v"] = vectors(p.v);
    d["id"] = scalars(p.id);
    d["material"] = scalars(p.material);
    d["set"] = scalars(p.set);
    if (!p.pscale.empty()) d["pscale"] = scalars(p.pscale);
    if (!p.Cd.empty()) d["Cd"] = vectors(p.Cd);
    if (!p.J.empty()) d["J"] = scalars(p.J);
    if (!p.Jp.empty()) d["Jp"] = scalars(p.Jp);
    if (!p.stressNorm.empty()) d["stress_norm"] = scalars(p.stressNorm);
    if (!p.plasticStrain.empty()) d["plastic_strain"] = scalars(p.plasticStrain);
    if (!p.F.empty()) d["F"] = matrices(p.F);
    for (const auto& [name, values] : p.parameters) d[py::str(name)] = scalars(values);
    return d;
}

py::dict statsDict(const FrameStats& s) {
    py::dict d;
    d["frame"] = s.frame;
    d["time"] = s.time;
    d["particles"] = s.particles;
    d["mass"] = s.mass;
    d["momentum"] = std::vector<double>{s.momentum[0], s.momentum[1], s.momentum[2]};
    d["angular_momentum"] = std::vector<double>{s.angularMomentum[0], s.angularMomentum[1], s.angularMomentum[2]};
    d["kinetic_energy"] = s.kineticEnergy;
    d["elastic_energy"] = s.elasticEnergy;
    d["gravity_energy"] = s.gravityEnergy;
    d["max_speed"] = s.maxSpeed;
    d["min_J"] = s.minJ;
    d["max_J"] = s.maxJ;
    d["substeps"] = s.substeps;
    d["retries"] = s.retries;
    return d;
}

/// Worker threads for a call: n, or all cores for 0.
std::unique_ptr<tbb::global_control> threadLimit(int threads) {
    const int n = threads > 0 ? threads : int(std::thread::hardware_concurrency());
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(n));
}

/// A scene built in memory and advanced frame by frame (nothing is written unless asked).
class PySimulation {
public:
    PySimulation(const std::string& scenePath, int threads)
        : threads_(threads), scene_(loadScene(scenePath)), layout_(speciesLayout(scene_)) {
        const auto limit = threadLimit(threads_);
        sim_ = buildSimulation(scene_);
        sim_->emitDue();
        attributes_ = PointAttributes::of(PointAttributes::names());
        for (const ParticleSetDesc& d : scene_.sets) attributes_.setColours.push_back(d.colour);
    }
    py::dict advance(int frames) {
        if (frames < 1) throw py::value_error("advance: frames must be at least 1");
        const auto limit = threadLimit(threads_);
        FrameStats st;
        {
            py::gil_scoped_release free;
            for (int f = 0; f < frames; ++f) st = sim_->advanceFrame();
        }
        return statsDict(st);
    }
    py::dict particles() const { return pointDict(gatherPoints(sim_->species(), layout_.materialOfSpecies, attributes_)); }
    py::dict stats() const { return statsDict(sim_->measure()); }
    /// Replaces every particle's velocity, in the order particles() lists them.
    void setVelocities(const py::array_t<float, py::array::c_style | py::array::forcecast>& v) {
        std::size_t n = 0;
        for (const AnySpecies& s : sim_->species()) n += particlesOf(s).size();
        if (v.ndim() != 2 || std::size_t(v.shape(0)) != n || v.shape(1) != 3)
            throw py::value_error("set_velocities: expected an array of shape (" + std::to_string(n) + ", 3)");
        std::vector<Vec3f> velocities(n);
        for (std::size_t k = 0; k < n; ++k) velocities[k] = Vec3f(v.data()[3 * k], v.data()[3 * k + 1], v.data()[3 * k + 2]);
        sim_->setVelocities(velocities);
    }
    /// Each rigid body now: its collider's index, mass, world inertia tensor and state.
    py::list bodies() const {
        py::list out;
        for (std::size_t k = 0; k < sim_->bodies().size(); ++k) {
            const Simulation::Body& b = sim_->bodies()[k];
            const RigidBodyState& s = sim_->state().bodies[k];
            py::dict d = bodyState(s);
            d["collider"] = b.collider;
            d["mass"] = b.model.mass;
            const Mat3d I = b.model.worldInertia(s.orientation);
            d["inertia"] = std::vector<std::vector<double>>{
                {I(0, 0), I(0, 1), I(0, 2)}, {I(1, 0), I(1, 1), I(1, 2)}, {I(2, 0), I(2, 1), I(2, 2)}};
            out.append(d);
        }
        return out;
    }
    /// fn(body, dt, impulse, angular_impulse, state) after every substep, in place of the built-in rigid-body solver
    /// (core/Simulation.h, setBodyDriver); it returns the state the next substep starts from (a dict with any of
    /// centre, orientation, velocity, spin), or None to leave it. None instead of fn restores the built-in solver.
    void setBodyDriver(py::object fn) {
        if (!fn.is_none() && !PyCallable_Check(fn.ptr()))
            throw py::type_error(
                "set_body_driver: expected a function fn(body, dt, impulse, angular_impulse, state) or None, got " +
                std::string(py::str(py::type::of(fn).attr("__name__"))));
        driver_ = fn;
        if (fn.is_none()) {
            sim_->setBodyDriver(nullptr);
            return;
        }
        sim_->setBodyDriver([this](std::size_t k, double dt, const Vec3d& J, const Vec3d& L, RigidBodyState& s) {
            py::gil_scoped_acquire hold;  // advance() runs the substeps without it
            const py::object r = driver_(k, dt, triple(J), triple(L), bodyState(s));
            if (!r.is_none()) applyDriverResult(k, r, s);
        });
    }
    int frame() const { return sim_->frame(); }
    double time() const { return sim_->time(); }
    std::vector<std::string> materialNames() const { return materialSceneNames(); }
    std::vector<std::string> setNames() const { return layout_.setNames; }

private:
    int threads_;
    SceneDesc scene_;
    SpeciesLayout layout_;
    std::unique_ptr<Simulation> sim_;
    PointAttributes attributes_;
    py::object driver_;

    static std::vector<double> triple(const Vec3d& v) { return {v[0], v[1], v[2]}; }
    /// What a body driver returned for body k, checked key by key: a mistake is an error naming the key, never
    /// silently ignored (a misspelt key would leave the body where it is).
    static void applyDriverResult(std::size_t k, const py::object& r, RigidBodyState& s) {
        const std::string where = "body driver (body " + std::to_string(k) + "): ";
        if (!py::isinstance<py::dict>(r))
            throw py::type_error(where + "return a dict with any of centre, orientation, velocity, spin, or None; got " +
                                 std::string(py::str(py::type::of(r).attr("__name__"))));
        const auto numbers = [&](const std::string& key, const py::handle& value, std::size_t count) {
            std::vector<double> v;
            try {
                v = value.cast<std::vector<double>>();
            } catch (const py::cast_error&) {
                throw py::type_error(where + key + " must be " + std::to_string(count) + " numbers");
            }
            if (v.size() != count) throw py::value_error(where + key + " must be " + std::to_string(count) + " numbers");
            for (double x : v)
                if (!std::isfinite(x)) throw py::value_error(where + key + " holds a value that is not finite");
            return v;
        };
        for (const auto& [keyObject, value] : r.cast<py::dict>()) {
            const std::string key = py::str(keyObject);
            if (key == "centre" || key == "velocity" || key == "spin") {
                const std::vector<double> v = numbers(key, value, 3);
                (key == "centre" ? s.centre : key == "velocity" ? s.velocity : s.spin) = Vec3d(v[0], v[1], v[2]);
            } else if (key == "orientation") {
                const std::vector<double> q = numbers(key + " (a quaternion w, x, y, z)", value, 4);
                const Eigen::Quaterniond turn(q[0], q[1], q[2], q[3]);
                if (!(turn.norm() > 1e-12)) throw py::value_error(where + "orientation must be a nonzero quaternion w, x, y, z");
                s.orientation = turn;
            } else {
                throw py::value_error(where + "unknown key \"" + key.substr(0, 40) +
                                      "\" in its result; the keys are centre, orientation, velocity, spin");
            }
        }
    }
    static py::dict bodyState(const RigidBodyState& s) {
        py::dict d;
        d["centre"] = triple(s.centre);
        d["orientation"] = std::vector<double>{s.orientation.w(), s.orientation.x(), s.orientation.y(), s.orientation.z()};
        d["velocity"] = triple(s.velocity);
        d["spin"] = triple(s.spin);
        return d;
    }
};

}  // namespace

PYBIND11_MODULE(sparse_mpm, m) {
    m.doc() = "sparse-mpm: read frames into numpy arrays, run scenes, advance them frame by frame";
    m.def(
        "read_frame",
        [](const std::string& path) {
            const PointsReadBack p = readVdbPoints(path);
            return pointDict(p);
        },
        py::arg("path"),
        "The points of a frame file (<scene>_NNNN.vdb or <scene>_points_NNNN.vdb): a dict of numpy arrays keyed by attribute "
        "name: P (n, 3) float64, v (n, 3) float32, id, material, set (int32), and pscale, Cd, J, Jp, stress_norm, "
        "plastic_strain, F (n, 3, 3) and the material parameters (density, youngs_modulus, poisson_ratio, bulk_modulus, "
        "viscosity, yield_stress) where the file has them.");
    m.def(
        "material_colours",
        [] {
            py::dict d;
            for (const std::string& name : materialSceneNames()) {
                const Vec3f c = defaultColour(name);
                d[py::str(name)] = py::make_tuple(c[0], c[1], c[2]);
            }
            return d;
        },
        "Each material's default colour of its points (linear RGB), by scene name: what a set takes unless it gives "
        "\"color\".");
    m.def(
        "read_bodies",
        [](const std::string& path) {
            const BodyPoints b = readVdbBodies(path);
            py::dict d;
            d["P"] = positions(b.x);
            d["orient"] = table<float>(b.orient, {4}, [](const std::array<float, 4>& q, float* o) {
                for (int a = 0; a < 4; ++a) o[a] = q[std::size_t(a)];
            });
            d["v"] = vectors(b.v);
            d["w"] = vectors(b.w);
            d["collider"] = scalars(b.collider);
            d["name"] = b.name;
            return d;
        },
        py::arg("path"),
        "The rigid bodies of a frame file (its grid \"bodies\", beside the points): a dict of numpy arrays, one row per "
        "body: P (centre of mass), orient (x, y, z, w, Houdini's order: the turn from the scene's placement), v, w "
        "(angular velocity), collider (the body's index in the scene's colliders) and name (a list: the collider's name in "
        "the scene); empty when it has none.");
    m.def(
        "read_frame_names",
        [](const std::string& path) {
            const PointsReadBack p = readVdbPoints(path);
            py::dict d;
            d["material_names"] = p.materialNames;
            d["set_names"] = p.setNames;
            d["groups"] = p.groupNames;
            py::dict members;
            for (const auto& [g, m] : p.groups) {
                py::array_t<bool> a(py::ssize_t(m.size()));
                for (std::size_t i = 0; i < m.size(); ++i) a.mutable_data()[i] = m[i];
                members[py::str(g)] = a;
            }
            d["group_members"] = members;
            return d;
        },
        py::arg("path"),
        "What a frame's indices mean: material_names and set_names (index -> name), groups (point group -> name) and "
        "group_members (point group -> bool array, in read_frame's order).");
    m.def(
        "run",
        [](const std::string& scene, const std::string& output, int threads) {
            const auto limit = threadLimit(threads);
            RunOptions options;
            options.outDir = output;
            SceneRun job(scene, options, RunEvents{});
            {
                py::gil_scoped_release free;
                job.run(nullptr);
            }
            return job.directory();
        },
        py::arg("scene"), py::arg("output") = "", py::arg("threads") = 0,
        "Runs a scene to its last frame as `mpm run` does (frames, stats.csv, checkpoints) into output (default: the "
        "scene's output.directory); returns the directory.");
    py::class_<PySimulation>(m, "Simulation",
                             "A scene built in memory, its sets emitted, advanced frame by frame; nothing is written to disk.")
        .def(py::init<const std::string&, int>(), py::arg("scene"), py::arg("threads") = 0)
        .def("advance", &PySimulation::advance, py::arg("frames") = 1, "Simulates frames; returns the last one's statistics.")
        .def("particles", &PySimulation::particles, "Every particle now: the dict read_frame returns, all attributes included.")
        .def("stats", &PySimulation::stats, "Statistics of the state now (mass, momentum, energies, ...).")
        .def("set_velocities", &PySimulation::setVelocities, py::arg("v"),
             "Sets every particle's velocity, in particles()' order.")
        .def("bodies", &PySimulation::bodies,
             "Each rigid body now (colliders with \"dynamic\"): a dict of collider (its index), mass, inertia (world, "
             "3x3), centre (of mass), orientation (w, x, y, z: the turn from the scene's placement), velocity, spin.")
        .def("set_body_driver", &PySimulation::setBodyDriver, py::arg("fn"),
             "Drives the rigid bodies from an outside solver: fn(body, dt, impulse, angular_impulse, state) is called for "
             "each body after every substep with the impulse and angular impulse (about the centre of mass) the material "
             "gave it in that substep and its state (a dict of centre, orientation, velocity and spin, moved to the pose "
             "the substep used, "
             "velocities as before); it returns the state the next substep starts from (a dict with any of centre, "
             "orientation, velocity, spin: what it leaves out stays as it was; None leaves all). It replaces gravity, the "
             "exchange and contact of the built-in solver; "
             "None instead of fn restores it.")
        .def_property_readonly("frame", &PySimulation::frame)
        .def_property_readonly("time", &PySimulation::time)
        .def_property_readonly("material_names", &PySimulation::materialNames)
        .def_property_readonly("set_names", &PySimulation::setNames);
    py::register_exception<SceneError>(m, "SceneError", PyExc_ValueError);
}
