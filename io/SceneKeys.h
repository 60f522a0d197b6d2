#pragma once
// The scene keys of the simulation settings, the output, a particle set and a collider, in the form of
// base/Parameters.h: the reader and `mpm validate --explain` walk these same functions. The keys of a
// material are in its header (materials/), those of a shape in its file (core/shapes/).
#include <algorithm>
#include <limits>
#include <sstream>
#include <string>

#include "io/PointCloud.h"
#include "io/SceneDesc.h"

namespace mpm {

inline constexpr Named<Interpolation> kInterpolations[] = {{Interpolation::Quadratic, "quadratic"},
                                                           {Interpolation::Cubic, "cubic"}};
inline constexpr Named<TransferScheme> kTransfers[] = {{TransferScheme::APIC, "apic"}, {TransferScheme::PIC, "pic"}};
inline constexpr Named<ForceScheme> kForces[] = {{ForceScheme::Standard, "standard"}, {ForceScheme::MLS, "mls"}};
inline constexpr Named<WallGhosts> kWallGhosts[] = {{WallGhosts::Held, "held"}, {WallGhosts::Mirror, "mirror"}};
inline constexpr Named<WallContact> kWallContacts[] = {{WallContact::Stencil, "stencil"}, {WallContact::Surface, "surface"}};
inline constexpr Named<ContactModel> kContactModels[] = {{ContactModel::SingleField, "single_field"},
                                                         {ContactModel::MultiField, "multi_field"}};
inline constexpr Named<Boundary> kBoundaries[] = {
    {Boundary::Sticky, "sticky"}, {Boundary::Slip, "slip"}, {Boundary::Separate, "separate"}};
inline constexpr Named<Sampling> kSamplings[] = {
    {Sampling::Poisson, "poisson"}, {Sampling::Grid, "grid"}, {Sampling::Lattice, "lattice"}};

inline constexpr Named<MaterialFieldDesc::Source> kFieldSources[] = {{MaterialFieldDesc::Source::Ramp, "ramp"},
                                                                     {MaterialFieldDesc::Source::Vdb, "vdb"},
                                                                     {MaterialFieldDesc::Source::Attribute, "attribute"}};

/// A key visitor that lists the names of the number keys it is shown.
struct NumberKeyNames : KeyVisitorArchetype {
    std::vector<std::string> names;
    template <class T>
    void number(const Key& k, T&) {
        names.emplace_back(k.name);
    }
};

/// The number keys of a material's material_params (those a material field may give per particle).
inline std::vector<std::string> materialNumberKeys(const std::string& material) {
    NumberKeyNames v;
    AnyMaterialParams p;
    if (defaultMaterialParams(material, p))
        visitMaterialParams(p, [&]<class M>(typename M::Params& params) { M::keys(v, params); });
    return v.names;
}

/// A material parameter given per particle (io/MaterialFields.h samples it).
template <class V>
void materialFieldKeys(V& v, MaterialFieldDesc& f, const std::string& material) {
    v.text(Key{.name = "param",
               .help = "the material parameter it gives, a number key of the set's material_params (youngs_modulus, density, "
                       "viscosity, yield_stress, ...)",
               .required = true},
           f.param);
    const std::vector<std::string> numbers = materialNumberKeys(material);
    std::string known;
    for (const std::string& n : numbers) known += (known.empty() ? "" : ", ") + n;
    v.check(std::find(numbers.begin(), numbers.end(), f.param) != numbers.end(), "param",
            "\"" + f.param + "\" is not a number of material " + material + "; its numbers: " + known);
    v.choice(Key{.name = "source",
                 .help = "ramp: linear from `from` to `to`, held beyond them; vdb: a float grid sampled (trilinearly) where each "
                         "particle is seeded; attribute: a vertex property of a points set's PLY file",
                 .required = true,
                 .noun = "field source"},
             f.source, std::span<const Named<MaterialFieldDesc::Source>>(kFieldSources));
    using Source = MaterialFieldDesc::Source;
    // A scene reads the keys of its source; the documentation (given() false) lists them all.
    if (f.source == Source::Ramp || !v.given("source")) {
        v.vec3(Key{.name = "from",
                   .help = "ramp: where it takes from_value (world coordinates, as the scene places the set); the value at "
                           "a particle x is from_value + t (to_value - from_value), t = (x - from) . (to - from) / |to - "
                           "from|^2 held to 0 .. 1",
                   .unit = "m"},
               f.from);
        v.vec3(Key{.name = "to", .help = "ramp: where it takes to_value", .unit = "m"}, f.to);
        v.number(Key{.name = "from_value", .help = "ramp: the value at `from`, in the parameter's unit", .required = true},
                 f.fromValue);
        v.number(Key{.name = "to_value", .help = "ramp: the value at `to`", .required = true}, f.toValue);
        v.check(f.source != Source::Ramp || (f.to - f.from).norm() > 0.0, "to", "must differ from `from`");
    }
    if (f.source == Source::Vdb || !v.given("source")) {
        v.text(Key{.name = "file",
                   .help = "vdb: the VDB file, relative to the scene file; its float grid is sampled trilinearly in world "
                           "space at each particle's seed, and gives its background value outside its active voxels"},
               f.file);
        if (!v.given("grid")) f.grid = f.param;
        v.text(Key{.name = "grid", .help = "vdb: its float grid", .byDefault = "the param's name"}, f.grid);
        v.check(f.source != Source::Vdb || !f.file.empty(), "file", "a vdb field needs a file");
    }
    if (f.source == Source::Attribute || !v.given("source")) {
        if (!v.given("attribute")) f.attribute = f.param;
        v.text(Key{.name = "attribute",
                   .help = "attribute: the vertex property of the set's PLY (a points set). A PLY with mass or density "
                           "columns gives its points' masses by itself, and then takes no density field",
                   .byDefault = "the param's name"},
               f.attribute);
    }
}

/// Calls f.template operator()<M>() for the material model M whose scene name is `material`; false when none is.
template <class F>
bool withMaterialNamed(const std::string& material, F&& f) {
    bool found = false;
    forEachMaterial(AllMaterials{}, [&]<class M>() {
        if (found || material != M::kSceneName) return;
        found = true;
        f.template operator()<M>();
    });
    return found;
}

/// The colour a set's points take unless the set gives one: its material's kColour (linear RGB; tools/render_blender.py
/// draws with it).
inline Vec3f defaultColour(const std::string& material) {
    Vec3f colour(0.6f, 0.6f, 0.6f);
    withMaterialNamed(material, [&]<class M>() { colour = Vec3f(M::kColour[0], M::kColour[1], M::kColour[2]); });
    return colour;
}

template <class V>
void simulationKeys(V& v, SceneDesc& d) {
    SimulationSettings& s = d.settings;
    StabilitySettings& b = s.stability;
    v.integer(Key{.name = "frames", .help = "frames to simulate", .lo = 1, .hi = 1e6}, d.frames);
    v.number(Key{.name = "fps", .help = "frame rate", .lo = 1e-3, .hi = 1e6, .unit = "frames per second"}, s.fps);
    v.integer(Key{.name = "substeps", .help = "substeps per frame: target dt = 1 / (fps * substeps)", .lo = 1, .hi = 1e6},
              s.substepsPerFrame);
    v.number(Key{.name = "dx", .help = "grid spacing", .lo = 1e-6, .hi = 1e6, .unit = "m"}, s.dx);
    v.vec3(Key{.name = "gravity", .help = "gravity (Y is up)", .unit = "m/s^2"}, s.gravity);
    v.choice(Key{.name = "interpolation", .help = "B-spline kernel", .noun = "interpolation"}, s.transfer.interpolation,
             std::span<const Named<Interpolation>>(kInterpolations));
    v.choice(Key{.name = "transfer", .help = "velocity transfer (PIC is dissipative)", .noun = "transfer"}, s.transfer.transfer,
             std::span<const Named<TransferScheme>>(kTransfers));
    v.choice(
        Key{.name = "force", .help = "stress force: grad w (thesis 3.24) or MLS-MPM fused (Hu et al. 2018)", .noun = "force"},
        s.transfer.force, std::span<const Named<ForceScheme>>(kForces));
    v.number(Key{.name = "cfl", .help = "C in dt <= C dx / (c + max speed), c the fastest wave speed", .lo = 1e-3, .hi = 10.0},
             s.cfl);
    v.number(Key{.name = "rebalance_imbalance",
                 .help = "on several ranks (mpirun): re-cut the leaves into equal shares when the most loaded rank holds this "
                         "fraction more particles than the mean, beyond what the last cut left; results never depend on it, "
                         "only the run time does (docs/distributed.md)",
                 .lo = 0.0,
                 .hi = 1e6},
             s.rebalanceImbalance);
    v.choice(
        Key{.name = "contact",
            .help = "bodies in contact: single_field (one velocity field, touching bodies move together there) or "
                    "multi_field (a field per body, which bounce and part; a body is a set, or the sets sharing a `body` name)",
            .noun = "contact model"},
        s.contact, std::span<const Named<ContactModel>>(kContactModels));
    v.number(Key{.name = "contact_friction", .help = "Coulomb friction between bodies (multi_field)", .lo = 0.0, .hi = 100.0},
             s.contactFriction);
    v.choice(Key{.name = "wall_ghosts",
                 .help = "nodes inside sticky and slip colliders: held at the wall's velocity, or mirror (on sticky and "
                         "frictionless slip walls "
                         "on the grid's lines or halfway between, such as axis-aligned planes and boxes: the nodes inside take "
                         "the velocity mirrored from their image "
                         "across the surface where that holds material resting on the wall, and the nodes before it their "
                         "images' mass and "
                         "stress impulse: no soft layer at the wall, second order for bodies held by it; material moving along "
                         "the normal by "
                         "over 0.1 cell a step (arriving, leaving) meets the held wall; tilted or curved walls and walls with "
                         "friction stay "
                         "held: as stable as held, see docs/validation/report.md)",
                 .noun = "wall ghosts"},
             s.wallGhosts, std::span<const Named<WallGhosts>>(kWallGhosts));
    v.choice(
        Key{.name = "wall_contact",
            .help = "where `separate` colliders act: stencil (on every node inside them, as sticky and slip colliders do: a "
                    "body arriving feels the wall from 1.5 cells away) or surface (once the material's surface, judged from the "
                    "node's mass, reaches theirs: contact times as Hertz's, but material resting in a corner or against a wall "
                    "below a free surface creeps into the wall, a water column a quarter cell a side, see docs/method.md)",
            .noun = "wall contact"},
        s.wallContact, std::span<const Named<WallContact>>(kWallContacts));
    v.flag(Key{.name = "adaptive", .help = "apply the CFL bound (off: the fixed target dt)"}, s.adaptive);
    v.number(Key{.name = "max_displacement",
                 .help = "thesis rule: largest grid-node displacement per substep in cells; 0 = off",
                 .lo = 0.0,
                 .hi = 100.0,
                 .unit = "cells per substep"},
             s.maxDisplacement);
    v.integer(Key{.name = "threads", .help = "worker threads; 0 = all cores (`--threads` overrides)", .lo = 0, .hi = 4096},
              d.threads);
    v.number(Key{.name = "energy_growth_limit",
                 .help = "blow-up check: total energy (kinetic + stored + gravity) may not rise above its lowest value since the "
                         "last emission by more than this fraction of the largest kinetic + stored energy seen; 0 = off",
                 .lo = 0.0,
                 .hi = 1e6,
                 .unit = "(fraction of the largest kinetic + stored energy; 0 = off)"},
             b.energyGrowth);
    v.flag(
        Key{.name = "cell_crossing_check", .help = "blow-up check: stop when a particle moves more than one cell in a substep"},
        b.cellCrossing);
    v.number(Key{.name = "step_collapse_limit",
                 .help = "blow-up check: stop when the CFL time step shrinks by more than this factor in one substep (a crushed "
                         "material or a flung particle would stall the run); 0 = off",
                 .lo = 0.0,
                 .hi = 1e12,
                 .unit = "(largest factor by which the CFL step may shrink in one substep; 0 = off)"},
             b.stepCollapse);
    v.integer(Key{.name = "max_substeps_per_frame",
                  .help = "watchdog: a scene whose frames would need more substeps fails validation, and a run stops at a frame "
                          "that would (instead of crawling on)",
                  .lo = 1,
                  .hi = 1e9},
              s.maxSubstepsPerFrame);
    v.integer(
        Key{.name = "retries",
            .help = "when a check fires (these three, a non-finite value, neo-Hookean J <= 0): 0 stops the run naming cause, "
                    "frame, substep and particle; N restarts the frame up to N times, halving the time step each time "
                    "(counted in stats.csv `retries`)",
            .lo = 0,
            .hi = 10},
        b.retries);
}

template <class V>
void outputKeys(V& v, OutputDesc& o) {
    v.text(Key{.name = "directory", .help = "where frames go (`-o` overrides)"}, o.directory);
    v.flag(Key{.name = "points",
               .help = "VDB PointDataGrid `points`: P, v, id, material, set, pscale, Cd, the attributes asked for; groups "
                       "material_<name>, set_<name>"},
           o.points);
    v.flag(Key{.name = "surface", .help = "narrow-band level set `surface` from the particles"}, o.surface);
    v.flag(Key{.name = "density", .help = "fog volume `density` (from the surface)"}, o.density);
    v.flag(Key{.name = "velocity", .help = "vector grid `vel` (mean particle velocity per voxel)"}, o.velocity);
    v.flag(
        Key{.name = "split_files",
            .help =
                "points in `<scene>_points_NNNN.vdb`, volumes in `<scene>_NNNN.vdb` (Blender and pyopenvdb cannot read points)"},
        o.splitFiles);
    v.flag(Key{.name = "ply",
               .help = "binary PLY `<scene>_NNNN.ply`: x, y, z in double, vx, vy, vz, id, material, set, pscale, red, green, "
                       "blue and the attributes asked for (Blender imports it)"},
           o.ply);
    v.flag(Key{.name = "initial_frame",
               .help = "also write the initial state as file 0000; file N holds the state at the end of frame N, from 1, "
                       "as Blender and Houdini number frames"},
           o.initialFrame);
    v.number(Key{.name = "surface_radius",
                 .help = "radius of the particles' spheres",
                 .lo = 0.5,
                 .hi = 10.0,
                 .unit = "particle spacings"},
             o.surfaceRadius);
    v.number(Key{.name = "surface_dilate",
                 .help = "grow each surface outward by this much before smoothing (fills gaps between particles)",
                 .lo = 0.0,
                 .hi = 3.0,
                 .unit = "particle spacings"},
             o.surfaceDilate);
    v.integer(Key{.name = "surface_smooth", .help = "Gaussian smoothing passes after dilating", .lo = 0, .hi = 20},
              o.surfaceSmooth);
    v.number(Key{.name = "surface_erode",
                 .help = "shrink each surface inward by this much after smoothing (back to the material)",
                 .lo = 0.0,
                 .hi = 3.0,
                 .unit = "particle spacings"},
             o.surfaceErode);
    v.integer(Key{.name = "checkpoint_every",
                  .help = "write the whole simulation state every this many frames (`--resume` continues from it); 0 = never",
                  .lo = 0,
                  .hi = 1e9},
              o.checkpointEvery);
    v.integer(Key{.name = "checkpoints_kept", .help = "the newest checkpoints kept; older ones are removed", .lo = 1, .hi = 1000},
              o.checkpointsKept);
    v.choices(
        Key{.name = "attributes",
            .help =
                "point attributes written beside P, v, id, material, set, pscale and Cd: J (volume ratio), Jp "
                "(plastic volume ratio), stress_norm (Cauchy stress, Frobenius norm, Pa), F (elastic deformation "
                "gradient, 3x3), plastic_strain (equivalent plastic strain of metal, the accumulated flow of a viscous liquid); "
                "and each particle's material parameters, its own where material_fields give them: density (its mass over "
                "its rest volume, kg/m^3), youngs_modulus and poisson_ratio (of a solid, 0 for a liquid), bulk_modulus (a "
                "liquid's k, a solid's lambda + 2 mu / 3), viscosity and yield_stress (0 for a model without them), after "
                "lambda_scale and mu_scale; the values given, not what hardening made of them",
            .noun = "point attribute"},
        o.attributes, PointAttributes::names());
    v.choice(
        Key{.name = "rank_files",
            .help =
                "on several ranks (mpirun): `gathered` has rank 0 write every frame as one process does (the same "
                "files and bits; up to what rank 0's memory holds, about 7e7 particles on 24 GiB with 2 ranks); `per_rank` has "
                "each rank write its own particles into part files `<scene>_NNNN_rankRRR.vdb` (and `_points_`, "
                "`.ply` alike) and its part of each checkpoint (`<scene>_checkpoint_NNNN_rankRRR.mpmc`), nothing "
                "gathered: load the frame parts together (Houdini: a File SOP per part, merged; Blender: one object "
                "each). A surface of parts is each part's own. A set of checkpoint parts resumes on any rank count, "
                "one process included; the output directory must be one that every rank sees",
            .noun = "rank file layout"},
        o.rankFiles, std::vector<std::string>{"gathered", "per_rank"});
    v.choice(Key{.name = "surface_group",
                 .help = "one `surface` grid, or `surface_<material>` / `surface_<set>` per group",
                 .noun = "surface grouping"},
             o.surfaceGroup, std::vector<std::string>{"all", "material", "set"});
}

/// The keys of a particle set itself; its `shape` and `material_params` are objects of their own.
template <class V>
void setKeys(V& v, ParticleSetDesc& d) {
    v.text(Key{.name = "name", .help = "unique name", .byDefault = "set<i>, i its index"}, d.name);
    v.choice(Key{.name = "material", .help = "material preset", .noun = "material"}, d.material, materialSceneNames());
    v.text(Key{.name = "body",
               .help = "multi_field contact: sets with one body name share a velocity field",
               .byDefault = "\"\": a body of its own"},
           d.body);
    v.vec3(Key{.name = "velocity", .help = "initial velocity", .unit = "m/s"}, d.velocity);
    if (!v.given("color")) d.colour = defaultColour(d.material);
    v.vec3(Key{.name = "color", .help = "colour of its points (Cd, linear RGB 0..1)", .byDefault = "the material's"}, d.colour);
    v.check(d.colour.minCoeff() >= 0.0f && d.colour.maxCoeff() <= 1.0f, "color", "components must lie in 0 .. 1");
    v.vec3(Key{.name = "angular_velocity",
               .help = "initial rigid spin about the pivot, added to velocity, right-handed",
               .unit = "rad/s"},
           d.angularVelocity);
    v.vec3(Key{.name = "pivot",
               .help = "centre of the spin; the resolved scene of a spinning set states the centroid it took",
               .unit = "m",
               .byDefault = "the set's centroid (its particles' mean, to 1e-4 of dx's decade)",
               .derived = true},
           d.pivot);
    d.pivotGiven = v.given("pivot");
    v.object(Key{.name = "velocity_field", .help = "an initial velocity field from a VDB, added to velocity"}, [&](auto& f) {
        f.text(Key{.name = "file", .help = "VDB file, relative to the scene file (empty: none)"}, d.velocityFile);
        f.text(Key{.name = "grid", .help = "its vector grid (Houdini's `vel`)"}, d.velocityGrid);
    });
    v.number(Key{.name = "particles_per_cell", .help = "sampling density in particles per dx^3", .lo = 1e-3, .hi = 1000.0},
             d.particlesPerCell);
    v.integer(Key{.name = "count", .help = "exact particle count (overrides particles_per_cell when > 0)", .lo = 0, .hi = 2e9},
              d.count);
    v.choice(Key{.name = "sampling",
                 .help = "Bridson Poisson-disk, a jittered lattice, or a regular lattice (for validation)",
                 .noun = "sampling"},
             d.sampling, std::span<const Named<Sampling>>(kSamplings));
    std::string emission = d.continuous ? "continuous" : "copies";
    v.choice(Key{.name = "emission",
                 .help = "copies: the whole shape at each emission frame; continuous: material flows in through a disc or "
                         "rectangle at the "
                         "set's velocity, substep by substep, from start_frame for duration frames",
                 .noun = "emission"},
             emission, std::vector<std::string>{"copies", "continuous"});
    d.continuous = emission == "continuous";
    v.integer(Key{.name = "start_frame", .help = "first emission", .lo = 0, .hi = 1e8}, d.startFrame);
    v.integer(
        Key{.name = "duration", .help = "emissions happen during [start_frame, start_frame + duration)", .lo = 1, .hi = 1e8},
        d.durationFrames);
    v.integer(Key{.name = "pause",
                  .help = "frames skipped between two emissions (a stream: 0; repeated throws: > 0)",
                  .lo = 0,
                  .hi = 1e8},
              d.pauseFrames);
    v.number(Key{.name = "lambda_scale",
                 .help = "scales the preset's lambda (water and viscous: the bulk modulus k)",
                 .lo = 0.0,
                 .hi = 1e6},
             d.lambdaScale);
    v.number(Key{.name = "mu_scale",
                 .help = "scales the preset's mu (viscous: the shear modulus G; water has none)",
                 .lo = 0.0,
                 .hi = 1e6},
             d.muScale);
    bool shear = true;
    withMaterialNamed(d.material, [&]<class M>() { shear = hasShearModulus<M>(); });
    // 1 is the resolved scene's own value (every key written), so only a scale that would change something is refused.
    v.check(shear || d.muScale == 1.0, "mu_scale",
            d.material + " has no shear modulus to scale; lambda_scale scales its bulk modulus");
    v.number(Key{.name = "mass_scale", .help = "scales particle mass", .lo = 1e-6, .hi = 1e6}, d.massScale);
    v.integer(Key{.name = "seed", .help = "sampling seed", .lo = 0, .hi = 4294967295.0, .byDefault = "set index + 1"}, d.seed);
    v.list(Key{.name = "material_fields",
               .help = "material parameters given per particle, each in place of its material_params value: a stiffness "
                       "or density that varies through the body. Sampled once, where each particle is seeded (a resumed run "
                       "keeps the values its checkpoint holds); each value must lie in the parameter's range"},
           d.materialFields, [&](auto& f, MaterialFieldDesc& field) { materialFieldKeys(f, field, d.material); });
    for (std::size_t k = 0; k < d.materialFields.size(); ++k)
        for (std::size_t j = 0; j < k; ++j)
            v.check(d.materialFields[j].param != d.materialFields[k].param, "material_fields",
                    "two fields give " + d.materialFields[k].param);
    v.check(!d.continuous || d.materialFields.empty(), "material_fields",
            "a stream enters as uniform material; parameters per particle need a sampled shape");
}

/// A collider's motion: constant velocity and spin, or keyframed poses (core/Motion.h).
template <class V>
void motionKeys(V& v, MotionDesc& m) {
    m.pivotGiven = v.given("pivot");
    v.vec3(Key{.name = "velocity", .help = "constant velocity", .unit = "m/s"}, m.velocity);
    v.vec3(Key{.name = "angular_velocity", .help = "constant angular velocity about the pivot, right-handed", .unit = "rad/s"},
           m.angularVelocity);
    v.vec3(
        Key{.name = "pivot",
            .help = "the point it turns about, and whose position keyframes give; the resolved scene states the centre it took",
            .unit = "m",
            .byDefault = "the collider's centre (a mesh's: its box's; a VDB's: the box of its inside voxels'; to 1e-4 of dx's "
                         "decade), a dynamic body's centre of mass",
            .derived = true},
        m.pivot);
    double previous = -std::numeric_limits<double>::infinity();
    v.list(Key{.name = "keyframes",
               .help = "poses by frame: position linear and rotation spherical linear between keys, held before the first and "
                       "after the last"},
           m.keyframes, [&](auto& k, KeyframeDesc& key) {
               key.positionGiven = k.given("position");
               k.number(Key{.name = "frame",
                            .help = "frame of this pose (fractional frames allowed)",
                            .lo = -1e9,
                            .hi = 1e9,
                            .required = true},
                        key.frame);
               k.vec3(Key{.name = "position",
                          .help = "where the pivot is",
                          .unit = "m",
                          .byDefault = "the pivot's rest position",
                          .derived = true},
                      key.position);
               k.object(Key{.name = "rotation", .help = "turn from the rest placement about the pivot"},
                        [&](auto& r) { Rotation::keys(r, key.rotation); });
               std::ostringstream order;
               order << "keyframes must come in increasing frame order (" << previous << ", then " << key.frame << ")";
               k.check(key.frame > previous, "frame", order.str());
               previous = key.frame;
           });
    v.check(m.keyframes.empty() || (m.velocity.isZero() && m.angularVelocity.isZero()), "keyframes",
            "give a constant motion (velocity, angular_velocity) or keyframes, not both");
}

/// Which world axes a rigid body's lock holds still.
inline const std::vector<std::string>& kAxisLocks() {
    static const std::vector<std::string> locks = {"none", "x", "y", "z", "xy", "xz", "yz", "xyz"};
    return locks;
}

/// The `type` names of the collider shapes a rigid body can be, "sphere, box, cylinder, mesh, vdb": those whose mass,
/// centre of mass and inertia come in closed form (massProperties, core/shapes/MassProperties.h), and those whose file
/// gives them (kBodyFromFile: a closed mesh, or a level set's zero crossing meshed, core/shapes/Polyhedron.h).
inline const std::string& bodyShapeNames() {
    static const std::string names = []<class... S>(std::variant<S...>*) {
        std::string n;
        const auto add = [&n](const char* type) { n += (n.empty() ? "" : ", ") + std::string(type); };
        (((
              requires(const S& s) { s.massProperties(); } || requires { S::kBodyFromFile; })
              ? add(S::kType)
              : void()),
         ...);
        return n;
    }(static_cast<ColliderShape*>(nullptr));
    return names;
}

/// A collider the material moves: a rigid body (core/RigidBody.h).
template <class V>
void dynamicKeys(V& v, DynamicDesc& d) {
    v.number(Key{.name = "density",
                 .help = "the body's density; its mass, centre of mass and inertia follow from its shape",
                 .lo = 1e-3,
                 .hi = 1e6,
                 .unit = "kg/m^3"},
             d.density);
    v.number(Key{.name = "mass",
                 .help = "the body's mass, when above 0 (replaces density times the shape's volume; the inertia scales with it)",
                 .lo = 0.0,
                 .hi = 1e12,
                 .unit = "kg"},
             d.mass);
    v.vec3(Key{.name = "velocity", .help = "initial velocity of its centre of mass", .unit = "m/s"}, d.velocity);
    v.vec3(Key{.name = "angular_velocity",
               .help = "initial angular velocity about its centre of mass, right-handed",
               .unit = "rad/s"},
           d.angularVelocity);
    v.choice(Key{.name = "lock_translation", .help = "world axes along which it does not move", .noun = "axis lock"},
             d.lockTranslation, kAxisLocks());
    v.choice(Key{.name = "lock_rotation", .help = "world axes about which it does not turn", .noun = "axis lock"}, d.lockRotation,
             kAxisLocks());
    v.number(Key{.name = "restitution",
                 .help = "of its contacts with colliders and other bodies (the larger of two bodies' counts): the speed it "
                         "leaves a contact at over the speed it met it; 0 stops, 1 bounces back whole (not with the material, "
                         "whose contact is the grid's)",
                 .lo = 0.0,
                 .hi = 1.0},
             d.restitution);
    v.number(Key{.name = "rolling_resistance",
                 .help = "coefficient of rolling resistance against colliders and other bodies (the larger of two bodies'): "
                         "rolling meets a couple of this times the normal force times the centre's height over the contact, "
                         "so a ball rolling on a floor slows at c g / (1 + I / (m r^2)) while friction keeps it rolling "
                         "(c <= 1.4 mu for a ball); it acts where a body rolls (a ball's point, a cylinder's line, a rounded "
                         "rock's few points: a face resists by its own normal forces, and a box on an edge is held within "
                         "atan(c) of balance); 0 rolls on for ever, as a rigid ball on a rigid floor does (an irregular rock "
                         "rocks on its faces); about 0.001 for steel on steel, 0.01-0.05 for a ball on a hard floor, 0.1-0.3 "
                         "on grass, sand or soil (not with the material, whose contact is the grid's)",
                 .lo = 0.0,
                 .hi = 1.0},
             d.rollingResistance);
    v.number(Key{.name = "animated_until",
                 .help = "with the collider's motion: it follows that motion until this time (in seconds: keyframe f is at "
                         "f / fps), moving the material without being moved by it (an animated rigid body, as Blender and "
                         "Houdini have them), then gravity and the material move it on from the velocity and spin the motion "
                         "had just before (held after its last key: at rest)",
                 .lo = 0.0,
                 .hi = 1e9,
                 .unit = "s"},
             d.animatedUntil);
}

/// The keys every collider has besides its shape's.
template <class V>
void colliderKeys(V& v, ColliderDesc& c) {
    v.text(Key{.name = "name",
               .help = "unique name among the colliders (a rigid body's `name` in each frame's bodies grid and in bodies.csv)",
               .byDefault = "collider<i>, i its index"},
           c.name);
    v.check(!c.name.empty(), "name", "must not be empty (Houdini matches bodies by it)");
    v.choice(Key{.name = "boundary",
                 .help = "separate: remove the normal velocity only when moving in (material leaves a wall it is not pressed "
                         "against); slip: remove it both ways (holds material on the wall, in tension too; with friction it lets "
                         "material leave as separate does); sticky: stop",
                 .noun = "boundary"},
             c.boundary, std::span<const Named<Boundary>>(kBoundaries));
    v.number(
        Key{.name = "friction",
            .help = "Coulomb coefficient (slip and separate; a wall with friction acts only where the material presses on it)",
            .lo = 0.0,
            .hi = 100.0},
        c.friction);
    v.flag(Key{.name = "inside", .help = "keep material inside it (a tank, a glass, a drum) instead of outside"}, c.inside);
    v.object(Key{.name = "motion", .help = "how it moves (none: static)"}, [&](auto& m) { motionKeys(m, c.motion); });
    c.dynamic.enabled = v.given("dynamic");
    static const std::string dynamicHelp = "makes it a rigid body the material moves, under gravity (" + bodyShapeNames() +
                                           "; not inside, and with a motion only until animated_until)";
    v.object(
        Key{.name = "dynamic", .help = dynamicHelp, .byDefault = "absent: it moves only as its motion says", .derived = true},
        [&](auto& d) { dynamicKeys(d, c.dynamic); });
    const MotionDesc& m = c.motion;
    const bool moves = !(m.velocity.isZero() && m.angularVelocity.isZero() && m.keyframes.empty() && !m.pivotGiven);
    const bool animated = c.dynamic.enabled && c.dynamic.animatedUntil > 0.0;
    v.check(!c.dynamic.enabled || !moves || animated, "dynamic",
            "a body the material moves follows a motion only until dynamic/animated_until, a time after 0 s; give that "
            "time, or leave out the motion (a body's initial velocity is dynamic/velocity)");
    v.check(!animated || moves, "dynamic",
            "animated_until: the collider has no motion to follow until then; give it a motion, or leave animated_until out");
    v.check(!animated || (c.dynamic.velocity.isZero() && c.dynamic.angularVelocity.isZero()), "dynamic",
            "an animated body leaves its animation at the motion's velocity and spin; leave out dynamic/velocity and "
            "angular_velocity");
    v.check(!c.dynamic.enabled || !c.inside, "dynamic", "a body the material moves keeps material outside it; leave out inside");
}

}  // namespace mpm
