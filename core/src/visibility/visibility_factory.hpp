// visibility_factory.hpp — builds the visibility method that VisibilityOptions::method names.
#pragma once

#include "visibility/visibility.hpp"

#include <memory>

namespace illumap {

// The method named in opt.method over `tree` (which must outlive the result): "exact"
// (raycast.hpp) or "seed" (seed_visibility.hpp); nullptr for VisMethod::None. Runs its set-up
// on ctx's workers with progress; throws Cancelled.
std::unique_ptr<VisibilityModel> make_visibility(Context& ctx, const Octree& tree,
                                                 const VisibilityOptions& opt);

}  // namespace illumap
