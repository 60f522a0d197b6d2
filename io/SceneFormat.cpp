// The scene format's reference, printed by `mpm validate --explain` and saved as docs/scene-format.md.
// Keep it in step with io/Scene.cpp, which holds the same defaults in code.
#include <string>

#include "io/Scene.h"

namespace mpm {

std::string explainSceneFormat() {
    std::string presets;
    for (const std::string& p : materialPresetNames()) presets += (presets.empty() ? "" : ", ") + p;
    return R"(# Scene format

A scene is one JSON object with the keys `simulation`, `output`, `sets` (required, at least one) and
`colliders`. Units are SI (m, s, kg, Pa). **Y is up** (as in Houdini); gravity defaults to (0, -9.81, 0).
Unknown keys are errors. `mpm validate SCENE` prints the scene with every default filled in.

## simulation
| key | default | allowed | meaning |
|---|---|---|---|
| frames | 48 | 1 .. 1e6 | frames to simulate |
| fps | 24 | > 0 | frames per second |
| substeps | 20 | >= 1 | substeps per frame: target dt = 1 / (fps * substeps) |
| dx | 0.02 | > 0 | grid spacing [m] |
| gravity | [0, -9.81, 0] | 3 numbers | [m/s^2] |
| interpolation | quadratic | quadratic, cubic | B-spline kernel |
| transfer | apic | apic, pic | velocity transfer (PIC is dissipative) |
| force | standard | standard, mls | stress force: grad w (thesis 3.24) or MLS-MPM fused (Hu et al. 2018) |
| cfl | 0.5 | 0.001 .. 10 | C in dt <= C dx / (c + max speed), c the fastest wave speed |
| adaptive | true | true, false | apply the CFL bound (off: fixed target dt) |
| max_displacement | 0 | 0 .. 100 | thesis rule: largest grid-node displacement per substep in cells; 0 = off |
| threads | 0 | >= 0 | worker threads; 0 = all cores (`--threads` overrides) |
| energy_growth_limit | 0.5 | >= 0 | blow-up check: total energy (kinetic + stored + gravity) may not rise above its lowest value since the last emission by more than this fraction of the largest kinetic + stored energy seen; 0 = off |
| cell_crossing_check | true | bool | blow-up check: stop when a particle moves more than one cell in a substep |
| step_collapse_limit | 100 | >= 0 | blow-up check: stop when the CFL time step shrinks by more than this factor in one substep (a crushed material or a flung particle would stall the run); 0 = off |
| retries | 0 | 0 .. 10 | when a check fires (these three, a non-finite value, neo-Hookean J <= 0): 0 stops the run naming cause, frame, substep and particle; N restarts the frame up to N times, halving the time step each time (counted in stats.csv `retries`) |

## output
| key | default | allowed | meaning |
|---|---|---|---|
| directory | out/<scene name> | path | where frames go (`-o` overrides) |
| points | true | bool | VDB PointDataGrid `points`: P, v, id, material, set |
| surface | true | bool | narrow-band level set `surface` from the particles |
| density | false | bool | fog volume `density` (from the surface) |
| velocity | false | bool | vector grid `vel` (mean particle velocity per voxel) |
| split_files | false | bool | points in `<scene>_points_NNNN.vdb`, volumes in `<scene>_NNNN.vdb` (Blender and pyopenvdb cannot read points) |
| ply | false | bool | binary PLY `<scene>_NNNN.ply` with x, y, z, vx, vy, vz, id (Blender imports it) |
| surface_radius | 1.0 | 0.5 .. 10 | sphere radius in particle spacings |
| surface_group | all | all, material, set | one `surface` grid, or `surface_<material>` / `surface_<set>` per group |

## sets (particle sets; each is emitted as a whole at its emission frames)
| key | default | allowed | meaning |
|---|---|---|---|
| name | set<i> | unique string | |
| material | water | )" + presets + R"( | material preset |
| material_params | {} | see below | overrides of the preset's parameters |
| shape | box | {type: box, min, max} or {type: sphere, center, radius} | region filled with particles |
| velocity | [0, 0, 0] | 3 numbers | initial velocity [m/s] |
| particles_per_cell | 8 | > 0 | sampling density in particles per dx^3 |
| count | 0 | >= 0 | exact particle count (overrides particles_per_cell when > 0) |
| sampling | poisson | poisson, grid, lattice | Bridson Poisson-disk, a jittered lattice, or a regular lattice (for validation) |
| start_frame | 0 | >= 0 | first emission |
| duration | 1 | >= 1 | emissions happen during [start_frame, start_frame + duration) |
| pause | 0 | >= 0 | frames skipped between two emissions (a stream: 0; repeated throws: > 0) |
| lambda_scale, mu_scale | 1 | >= 0 | scale the preset's Lame parameters (water: lambda_scale scales k) |
| mass_scale | 1 | > 0 | scale particle mass |
| seed | set index + 1 | integer | sampling seed |

Particle volume is the shape volume divided by the particle count; mass is volume times density.

### material presets and their parameters (`material_params`)
- **water**: density 1000 kg/m^3, bulk_modulus 5e4 Pa, gamma 4 (the thesis's k = 50 at rho = 1, scaled
  with the density so that the sound speed sqrt(k gamma / rho) = 14.1 m/s is the same), tension false
  (water holds no tension: expansion past the rest volume is a free surface or spray, J is clamped to 1;
  true keeps the thesis's EOS, whose negative pressure makes free-surface water cohesive).
- **jelly** (fixed corotated) and **rubber** (neo-Hookean): density 400, youngs_modulus 1.4e5 Pa,
  poisson_ratio 0.2. Neo-Hookean is undefined for inverted elements (J <= 0): such a run stops with the
  particle, frame and substep named.
- **snow** (Stomakhin 2013): as jelly plus theta_c 0.025, theta_s 0.0075, xi 10.
- **sand** (Drucker-Prager, Klar 2016): density 2200, youngs_modulus 3.537e7, poisson_ratio 0.2,
  h0 35, h1 9, h2 0.2, h3 10 (degrees; friction angle phi = h0 + (h1 q - h3) exp(-h2 q)),
  volume_correction true (Tampubolon 2017).
lambda_scale and mu_scale multiply the Lame parameters computed from E and nu.

## colliders
| key | default | allowed | meaning |
|---|---|---|---|
| type | plane | plane, sphere | |
| point, normal | [0,0,0], [0,1,0] | 3 numbers | plane through point; material stays on the normal's side |
| center, radius | required | | sphere |
| boundary | slip | sticky, slip, separate | sticky: stop; slip: remove normal velocity; separate: only when moving in |
| friction | 0 | >= 0 | Coulomb coefficient (slip and separate) |
)";
}

}  // namespace mpm
