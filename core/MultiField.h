#pragma once
// Multi-body contact on shared grid nodes (simulation.contact = "multi_field"): every body scatters into a
// velocity field of its own (its own SparseGrid), and where two or more bodies have mass at one node the
// fields are made to agree only as far as contact asks (Bardenhagen et al. 2000, "The material-point method
// for granular materials", sec. 3): with the centre-of-mass velocity v_cm = sum m_b v_b / sum m_b and body b's
// outward normal n_b, a body approaching the others, (v_b - v_cm) . n_b > 0, loses that normal part, and its
// tangential part relative to v_cm is cut by Coulomb friction mu (v_b - v_cm) . n_b, or removed while the
// friction covers it. Bodies moving apart are left alone: they part instead of sticking.
// Normals follow Huang et al. 2011 ("Contact algorithms for the material point method in impact and
// penetration simulation", IJNME 85) in form, n_b along sum_{c != b} grad f_c - grad f_b, so two bodies at a node
// get opposite normals and the contact conserves momentum exactly; but f_b is body b's share of the node's mass,
// m_b / sum_c m_c, not its mass, and its gradient is Sobel's smoothed central difference over the 27 nodes around.
// Measured on two spheres meeting along a diagonal of the grid (R/dx = 8, E = 1e3): the mass's central
// difference lost 14.4% of the energy (one shared field 14.1%), its Sobel difference 13.4%, the share's 12.8%,
// the exact normal 12.7%: a sphere's mass thins towards its surface, which turns a mass gradient, not a share's.
// Contact starts where the bodies first share nodes: a volume-fraction test
// (Lemiale et al. 2010: contact only where the bodies' volumes fill the node's cell) was measured on the
// two-sphere case and lost more energy (8.4% against 4.9% at R/dx = 8), the bodies overlapping before it acts.
#include <functional>
#include <vector>

#include "sparse/SparseGrid.h"

namespace mpm {

struct FieldContactSummary {
    std::size_t nodes = 0;     ///< nodes where two or more bodies met
    std::size_t contacts = 0;  ///< (node, body) pairs that approached and got the contact condition
};

/// Applies the contact condition on every node that more than one field has mass at. The fields hold
/// velocities (after gravity, before colliders). Each node is handled by one task, the one visiting the lowest field that has
/// mass there, so the result does not depend on the thread count.
///
/// On ranks (`remote` given) only owned leaves are handled (a leaf coordinate has one owner in every field), and
/// the masses a normal reads in leaves other ranks own come from their owners through `remote.fetch`, called
/// once per field on every rank (collective): the same masses one process reads, so the same bits.
struct RemoteFields {
    std::vector<const std::vector<uint8_t>*> owned;  ///< per field, per leaf: owned by this rank
    std::function<bool(const Vec3i& node)> local;    ///< whether this rank owns the node's leaf
    /// The owners' masses of field `field` at the nodes, in order.
    std::function<void(std::size_t field, const std::vector<Vec3i>& nodes, std::vector<float>& mass)> fetch;
};
FieldContactSummary resolveFieldContact(std::vector<SparseGrid>& fields, float friction, const RemoteFields* remote = nullptr);

}  // namespace mpm
