// surfel_field.hpp — the surfels' values looked up at a point of a surface: what a gather ray
// that meets a triangle takes (the nearest surfels whose normal agrees with the surface's, by
// inverse squared distance, and that no triangle separates from the point).
#pragma once

#include "geometry/knn.hpp"
#include "visibility/mesh_scene.hpp"

#include <cstddef>
#include <vector>

namespace illumap {

class SurfelField {
public:
    // positions, normals, values: n x 3. k nearest surfels are looked at; those whose normal is
    // within acos(min_cos) of the surface's count. light_field: the values are light (the
    // gather's), which walls seal off (below). Throws std::invalid_argument for n == 0.
    SurfelField(const double* positions, const double* normals, const double* values,
                std::size_t n, int k, double min_cos, bool light_field = false);
    // Value at point q on a surface with unit normal nrm; best is the caller's scratch heap.
    // With `scene`, a surfel counts only if no triangle separates it from q (both lifted
    // `lift` metres off the surface; in a field of light first lifted a quarter of their
    // distance, then `lift` where none is seen so): light under a box does not spill out past
    // its side. Where none of the k counts, the nearest of them that q sees, whatever its
    // normal; where none is seen (q is walled off), black in a field of light, else the
    // nearest.
    void at(const double q[3], const double nrm[3], KdTree::Best& best, double out[3],
            const MeshScene* scene = nullptr, double lift = 0.0) const;
    std::size_t size() const { return values_.size() / 3; }
    // Surfel i's own value (i < size()).
    const double* value(std::size_t i) const { return &values_[3 * i]; }
    int k() const { return k_; }
    // Median distance to the k-th nearest surfel (m): about 1.6 surfel spacings at k = 8.
    double reach() const { return reach_; }

private:
    KdTree tree_;
    std::vector<double> positions_, normals_, values_;
    int k_;
    double min_cos_, eps2_, reach_;
    bool light_field_;
};

}  // namespace illumap
