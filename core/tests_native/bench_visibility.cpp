// bench_visibility.cpp — visibility precomputation on an occluded scene of N surfels:
// a 10 x 10 x 4 room (inward normals), a partition wall with a door, and 6 boxes.
// Prints times, rays/s, pair counts per class and peak memory.
//   usage: bench_visibility N [exact|seed] [threads] [samples]
#include "vis_test_util.hpp"

#include <cstring>
#include <fstream>
#include <sys/resource.h>
#include <string>

using namespace vt;

static long peak_rss_kb() {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line))
        if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
    return -1;
}

static double cpu_seconds() {
    rusage u;
    getrusage(RUSAGE_SELF, &u);
    return u.ru_utime.tv_sec + 1e-6 * u.ru_utime.tv_usec + u.ru_stime.tv_sec + 1e-6 * u.ru_stime.tv_usec;
}

static Scene occluded_scene(double N) {
    // total area: room 2*(100) + 4*(10*4) = 360; wall 2 sides * (10*4 - door 2) = 76; boxes.
    struct Bx { double lo[3], hi[3]; };
    const Bx boxes[6] = {{{1, 1, 0}, {2.5, 2, 1.2}},   {{6, 1.5, 0}, {7, 3, 2}},
                         {{2, 6, 0}, {3, 8.5, 0.8}},   {{7, 6.5, 0}, {9, 7.5, 3}},
                         {{4, 3.5, 1.5}, {4.8, 4.3, 2.3}}, {{1, 8, 2.5}, {3, 9, 3.0}}};
    double area = 360 + 76;
    for (auto& b : boxes) {
        const double dx = b.hi[0] - b.lo[0], dy = b.hi[1] - b.lo[1], dz = b.hi[2] - b.lo[2];
        area += 2 * (dx * dy + dy * dz + dz * dx);
    }
    const double h = std::sqrt(area / N);
    Scene s;
    const double r0[3] = {0, 0, 0}, r1[3] = {10, 10, 4};
    s.box(r0, r1, h, -1, 0, 0, 0.3);
    // partition wall x = 5 (two-sided: two layers 1 cm apart), door y in [4, 5], z in [0, 2]
    for (int side = 0; side < 2; ++side) {
        const double x = side ? 5.005 : 4.995, nx = side ? 1.0 : -1.0;
        const double nrm[3] = {nx, 0, 0};
        const double pieces[3][4] = {{0, 0, 4, 4}, {5, 0, 5, 4}, {4, 2, 1, 2}};  // y0 z0 dy dz
        for (auto& p : pieces) {
            const double o[3] = {x, p[0], p[1]}, u[3] = {0, p[2], 0}, v[3] = {0, 0, p[3]};
            s.rect(o, u, v, std::max(1, int(p[2] / h)), std::max(1, int(p[3] / h)), nrm, 0, 0.3, 7 + side);
        }
    }
    for (auto& b : boxes) s.box(b.lo, b.hi, h, +1, 0, 1 << 4, 0.3);
    return s;
}

int main(int argc, char** argv) {
    const double N = argc > 1 ? std::atof(argv[1]) : 1e5;
    const std::string method = argc > 2 ? argv[2] : "exact";
    if (method != "exact" && method != "seed") {
        std::fprintf(stderr, "method must be 'exact' or 'seed', not '%s'\n", method.c_str());
        return 2;
    }
    const int threads = argc > 3 ? std::atoi(argv[3]) : 0;
    const int samples = argc > 4 ? std::atoi(argv[4]) : 16;
    Scene sc = occluded_scene(N);
    std::printf("scene: N = %zu surfels, method %s, threads %d, samples %d\n", sc.size(), method.c_str(),
                threads ? threads : hardware_threads(), samples);
    Built b;
    double t = now();
    build(b, sc, 32, threads);
    std::printf("octree: %.2f s, %zu nodes, %zu leaves, depth %d\n", now() - t, b.tree.nodes.size(),
                b.tree.leaves.size(), b.tree.depth);
    { Scene tmp; std::swap(tmp, sc); }

    VisibilityOptions o;
    o.method = method == "seed" ? VisMethod::Seed : VisMethod::Exact;
    o.samples = samples;
    if (std::getenv("PACKETS")) o.packets = true;
    apply_env(o);
    std::printf("shape: %s\n", o.shape == VisibilityOptions::Shape::Quad      ? "quad"
                              : o.shape == VisibilityOptions::Shape::Octagon ? "octagon"
                                                                             : "disc");
    const bool skip_rays = std::getenv("NORAYBENCH") != nullptr;
    const double t_all = now();
    t = now();
    auto vis = make_visibility(b.ctx, b.tree, o);
    const double t_build = now() - t;
    std::printf("build (%s): %.2f s, ~%.0f MB\n", vis->name(), t_build, vis->stats().bytes / 1e6);

    // Raw rays/s on random facing pairs (mixed lengths, the hard incoherent case).
    if (o.method == VisMethod::Exact && !skip_rays) {
        auto* rc = static_cast<RaycastVisibility*>(vis.get());
        const std::size_t M = 4000000;
        std::vector<std::uint32_t> I, J;
        I.reserve(M); J.reserve(M);
        std::uint64_t st = 12345;
        const std::size_t n = b.tree.s.n;
        while (I.size() < M) {
            st = vis_mix(st);
            const std::uint32_t i = std::uint32_t((st & 0xffffffff) * n >> 32), j = std::uint32_t((st >> 32) * n >> 32);
            if (i != j && vis_facing(b.tree.s, i, j)) { I.push_back(i); J.push_back(j); }
        }
        std::vector<float> out(M);
        const std::uint64_t q0 = vis->stats().queries;
        t = now();
        parallel_for(b.ctx, M, 4096, [&](std::size_t lo, std::size_t hi) { rc->pairs(&I[lo], &J[lo], hi - lo, &out[lo]); });
        const double dt = now() - t;
        std::printf("(load: wall %.2f s)\n", dt);
        double vis_frac = 0;
        for (float v : out) vis_frac += v;
        std::printf("random facing rays: %zu in %.2f s = %.2f Mrays/s (visible %.3f)\n",
                    std::size_t(vis->stats().queries - q0), dt, (vis->stats().queries - q0) / dt / 1e6, vis_frac / M);
        // Short rays (leaf neighbourhood, the near field's case).
        I.clear(); J.clear();
        for (std::int32_t l : b.tree.leaves) {
            const OctreeNode& L = b.tree.nodes[l];
            for (std::uint32_t i = L.begin; i < L.end && I.size() < M; ++i) {
                st = vis_mix(st);
                std::uint32_t j = std::uint32_t(std::min<std::uint64_t>(n - 1, std::uint64_t(i) + 1 + (st % 200)));
                if (vis_facing(b.tree.s, i, j)) { I.push_back(i); J.push_back(j); }
            }
        }
        const std::uint64_t q1 = vis->stats().queries;
        t = now();
        parallel_for(b.ctx, I.size(), 4096, [&](std::size_t lo, std::size_t hi) { rc->pairs(&I[lo], &J[lo], hi - lo, &out[lo]); });
        const double dt2 = now() - t;
        std::printf("short facing rays (neighbours in tree order): %llu in %.2f s = %.2f Mrays/s\n",
                    (unsigned long long)(vis->stats().queries - q1), dt2, (vis->stats().queries - q1) / dt2 / 1e6);
        vis->reset_stats();
    }

    // The talk's Octree_Visibility over the MAC interaction lists (theta 0.5).
    const double t_rays_bench = now() - t_all - t_build;  // excluded from the total
    Traversal tr(b.tree, 0.5);
    t = now();
    const double cpu0 = cpu_seconds();
    VisLists L = octree_visibility(b.ctx, *vis, tr);
    const double t_class = now() - t;
    const double cpu_class = cpu_seconds() - cpu0;
    // Near field: per-pair visibility of the leaf pairs left PARTIAL (each unordered pair once).
    t = now();
    std::vector<std::size_t> todo;
    for (std::size_t k = 0; k < L.leaf_partial.a.size(); ++k)
        if (L.leaf_partial.a[k] <= L.leaf_partial.b[k]) todo.push_back(k);
    std::atomic<std::uint64_t> bytes{0};
    parallel_for(b.ctx, todo.size(), 16, [&](std::size_t lo, std::size_t hi) {
        std::vector<float> blk;
        for (std::size_t x = lo; x < hi; ++x) {
            const std::size_t k = todo[x];
            const std::int32_t a = L.leaf_partial.a[k], bb = L.leaf_partial.b[k];
            blk.resize(std::size_t(b.tree.nodes[a].count()) * b.tree.nodes[bb].count());
            vis->block(a, bb, blk.data());
            bytes += blk.size();  // stored as 1 byte per pair by the traversal (0/1)
        }
    });
    // Far leaf pairs left PARTIAL got their fraction from classify_fraction() above.
    std::size_t nfar = 0;
    for (std::size_t k = 0; k < L.far_partial.a.size(); ++k) nfar += L.far_partial.a[k] <= L.far_partial.b[k];
    const double t_near = now() - t;
    std::printf("far partial leaf pairs (fraction): %zu unordered\n", nfar);
    VisStats st = vis->stats();
    std::printf("classify CPU time %.2f s (%.2f Mrays per CPU-second)\n", cpu_class, vis->stats().queries / cpu_class / 1e6);
    std::printf("classify: %zu node pairs in %zu rounds, %.2f s | valid %zu invalid %zu leaf-partial %zu\n",
                L.classified, L.rounds, t_class, L.valid.a.size(), L.invalid, L.leaf_partial.a.size());
    std::printf("near per-pair blocks: %zu unordered leaf pairs, %llu pairs, %.2f s, %.0f MB at 1 byte/pair\n",
                todo.size(), (unsigned long long)st.block_pairs, t_near, bytes.load() / 1e6);
    std::printf("queries (rays / point_visible): %llu total, no-facing pairs %llu\n", (unsigned long long)st.queries,
                (unsigned long long)st.no_facing);
    std::printf("per level [valid invalid partial]:");
    for (std::size_t l = 0; l < st.per_level.size(); ++l)
        std::printf(" L%zu[%llu %llu %llu]", l, (unsigned long long)st.per_level[l][0],
                    (unsigned long long)st.per_level[l][1], (unsigned long long)st.per_level[l][2]);
    const double total = now() - t_all - t_rays_bench;
    std::printf("\nTOTAL visibility precompute (build + classify + near): %.2f s  (%.2f Mrays/s overall)  peak RSS %.0f MB\n",
                total, st.queries / total / 1e6, peak_rss_kb() / 1024.0);
    return 0;
}
