// Linked into the native test programs of scripts/portable_native_tests.py with
// -Wl,--wrap=rtcNewDevice: every Embree device the visibility code makes gets the settings in
// ILLUMAP_EMBREE_CONFIG appended to its own ("isa=sse2" forces Embree's SSE2 kernels on any
// CPU, "verbose=2" prints which BVH each scene gets). The core's sources stay untouched.
#include <cstdlib>
#include <string>

#include <embree3/rtcore.h>

extern "C" RTCDevice __real_rtcNewDevice(const char* config);

extern "C" RTCDevice __wrap_rtcNewDevice(const char* config) {
    std::string merged = config ? config : "";
    const char* extra = std::getenv("ILLUMAP_EMBREE_CONFIG");
    if (extra && *extra) merged += (merged.empty() ? "" : ",") + std::string(extra);
    return __real_rtcNewDevice(merged.c_str());
}
