// visibility_factory.cpp — VisMethod -> the visibility method (visibility_factory.hpp).
#include "visibility/visibility_factory.hpp"

#include "visibility/raycast.hpp"
#include "visibility/seed_visibility.hpp"

namespace illumap {

std::unique_ptr<VisibilityModel> make_visibility(Context& ctx, const Octree& tree,
                                                 const VisibilityOptions& opt) {
    switch (opt.method) {
        case VisMethod::Exact: return std::make_unique<RaycastVisibility>(ctx, tree, opt);
        case VisMethod::Seed: return std::make_unique<SeedVisibility>(ctx, tree, opt);
        case VisMethod::None: break;
    }
    return nullptr;
}

}  // namespace illumap
