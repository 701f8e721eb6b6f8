// parallel.hpp — a minimal parallel_for with progress reporting and cancellation.
//
// Workers pull chunks from an atomic counter (dynamic load balance: FMM work per node is very
// uneven). With two or more workers the calling thread does no work itself: it waits and,
// about every 50 ms, asks the Monitor (implemented by the bindings, which re-acquire the GIL
// there) whether to go on. With one (threads=1, or a single chunk) the calling thread runs the
// chunks and asks between them: starting and joining a thread cost more than a small phase
// (a 50-surfel solve took 0.82 ms, 0.34 ms without).
// This file knows nothing about Python.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <sched.h>
#endif

namespace illumap {

// Thrown when a run was cancelled by its monitor.
struct Cancelled : std::runtime_error {
    Cancelled() : std::runtime_error("cancelled") {}
};

// Receives progress from the calling thread; returns false to cancel.
class Monitor {
public:
    virtual ~Monitor() = default;
    virtual bool poll(double fraction, const char* phase) = 0;
};

// The CPUs this process may use: its affinity mask and its cgroup's CPU quota (a 4-CPU farm
// slot or container on a 64-core host), within the hardware's threads. Read once.
inline int available_cpus() {
    static const int cpus = [] {
        unsigned hw = std::thread::hardware_concurrency();
        int n = hw ? int(hw) : 1;
#if defined(__linux__)
        cpu_set_t set;
        CPU_ZERO(&set);
        if (sched_getaffinity(0, sizeof(set), &set) == 0 && CPU_COUNT(&set) > 0)
            n = std::min(n, int(CPU_COUNT(&set)));
        auto quota = [](const char* path, bool v2) -> double {
            std::FILE* f = std::fopen(path, "r");
            if (!f) return 0.0;
            char a[64] = {0};
            long long period = 0;
            const int got = v2 ? std::fscanf(f, "%63s %lld", a, &period) : std::fscanf(f, "%63s", a);
            std::fclose(f);
            if (got < 1 || std::string(a) == "max" || a[0] == '-') return 0.0;
            const double q = std::atof(a);
            return v2 ? (period > 0 ? q / double(period) : 0.0) : q;
        };
        double share = quota("/sys/fs/cgroup/cpu.max", true);
        if (!(share > 0)) {
            const double q = quota("/sys/fs/cgroup/cpu/cpu.cfs_quota_us", false);
            const double p = quota("/sys/fs/cgroup/cpu/cpu.cfs_period_us", false);
            share = (q > 0 && p > 0) ? q / p : 0.0;
        }
        if (share > 0) n = std::min(n, std::max(1, int(std::ceil(share))));
#endif
        return std::max(n, 1);
    }();
    return cpus;
}

// The default worker count: ILLUMAP_THREADS when set to a positive integer (Blender's -t, a
// farm's slot, or a test comparing thread counts), else every CPU this process may use
// (``available_cpus``). Results do not depend on it.
inline int hardware_threads() {
    if (const char* env = std::getenv("ILLUMAP_THREADS")) {
        char* end = nullptr;
        const long n = std::strtol(env, &end, 10);
        if (end != env && *end == '\0' && n > 0 && n <= 4096) return int(n);
    }
    return available_cpus();
}

// Execution context shared by the phases of one call: thread count, monitor, and the slice
// [base, base + span) of the overall progress that the current phase covers.
struct Context {
    int threads = 0;                 // 0: all hardware threads
    Monitor* monitor = nullptr;
    std::atomic<bool> cancel{false};
    const char* phase = "";
    double base = 0.0, span = 1.0;

    int nthreads() const { return threads > 0 ? threads : hardware_threads(); }
    void set_phase(const char* name, double b, double s) { phase = name; base = b; span = s; }
};

// parallel_for with a single worker: the chunks run on the calling thread, which polls the
// monitor between them (at most every ~50 ms).
template <class Fn>
void run_inline(Context& ctx, std::size_t n, std::size_t grain, std::size_t nchunks, Fn& fn) {
    using Clock = std::chrono::steady_clock;
    auto last = Clock::now();
    try {
        for (std::size_t c = 0; c < nchunks; ++c) {
            if (ctx.cancel.load(std::memory_order_relaxed)) break;
            const std::size_t b = c * grain, e = std::min(n, b + grain);
            fn(b, e);
            if (ctx.monitor && c + 1 < nchunks &&
                Clock::now() - last > std::chrono::milliseconds(50)) {
                last = Clock::now();
                bool go = true;
                try {
                    go = ctx.monitor->poll(ctx.base + ctx.span * double(e) / double(n),
                                           ctx.phase);
                } catch (...) {
                    go = false;
                }
                if (!go) ctx.cancel.store(true);
            }
        }
    } catch (...) {
        ctx.cancel.store(true);
        throw;
    }
    if (ctx.cancel.load()) throw Cancelled();
}

// parallel_for on nw new worker threads; the calling thread waits and polls the monitor.
template <class Fn>
void run_threads(Context& ctx, std::size_t n, std::size_t grain, std::size_t nchunks, int nw,
                 Fn&& fn) {
    std::atomic<std::size_t> next{0}, done{0};
    std::atomic<int> running{nw};
    std::exception_ptr error;
    std::mutex m;
    std::condition_variable cv;

    auto worker = [&] {
        try {
            for (;;) {
                if (ctx.cancel.load(std::memory_order_relaxed)) break;
                std::size_t c = next.fetch_add(1);
                if (c >= nchunks) break;
                std::size_t b = c * grain, e = std::min(n, b + grain);
                fn(b, e);
                done.fetch_add(e - b, std::memory_order_relaxed);
            }
        } catch (...) {
            std::lock_guard<std::mutex> lk(m);
            if (!error) error = std::current_exception();
            ctx.cancel.store(true);
        }
        {
            std::lock_guard<std::mutex> lk(m);
            running.fetch_sub(1);
        }
        cv.notify_one();
    };

    std::vector<std::thread> pool;
    pool.reserve(nw);
    for (int t = 0; t < nw; ++t) pool.emplace_back(worker);

    // The calling thread only watches: progress every ~50 ms, cancellation on request.
    {
        std::unique_lock<std::mutex> lk(m);
        while (running.load() > 0) {
            cv.wait_for(lk, std::chrono::milliseconds(50));
            if (running.load() == 0) break;
            if (ctx.monitor && !ctx.cancel.load()) {
                lk.unlock();
                bool go = true;
                try {
                    go = ctx.monitor->poll(ctx.base + ctx.span * double(done.load()) / double(n),
                                           ctx.phase);
                } catch (...) {
                    go = false;
                }
                if (!go) ctx.cancel.store(true);
                lk.lock();
            }
        }
    }
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
    if (ctx.cancel.load()) throw Cancelled();
}

// Calls fn(begin, end) over [0, n) in chunks of `grain`, on ctx.nthreads() workers.
// Throws Cancelled if the monitor asked to stop; rethrows the first worker exception.
template <class Fn>
void parallel_for(Context& ctx, std::size_t n, std::size_t grain, Fn&& fn) {
    if (ctx.cancel.load()) throw Cancelled();
    if (n == 0) return;
    grain = std::max<std::size_t>(grain, 1);
    const std::size_t nchunks = (n + grain - 1) / grain;
    const int nw = int(std::min<std::size_t>(std::size_t(ctx.nthreads()), nchunks));
    if (nw == 1)  // one worker: the calling thread itself (no thread to start and join)
        run_inline(ctx, n, grain, nchunks, fn);
    else
        run_threads(ctx, n, grain, nchunks, nw, fn);
}

// Runs fn() on one worker thread while the calling thread polls the monitor (~every 50 ms):
// for one long job that checks ctx.cancel itself (Embree's BVH build), which run_inline could
// neither report nor cancel.
template <class Fn>
void run_watched(Context& ctx, Fn&& fn) {
    run_threads(ctx, 1, 1, 1, 1, [&](std::size_t, std::size_t) { fn(); });
}

// Polls the monitor from the calling thread (between phases) so that even short runs report
// progress and can be cancelled.
inline void checkpoint(Context& ctx, double fraction) {
    if (ctx.cancel.load()) throw Cancelled();
    if (!ctx.monitor) return;
    bool go = false;
    try {
        go = ctx.monitor->poll(fraction, ctx.phase);
    } catch (...) {
        go = false;
    }
    if (!go) {
        ctx.cancel.store(true);
        throw Cancelled();
    }
}

}  // namespace illumap
