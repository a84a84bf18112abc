#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#if defined(__SANITIZE_THREAD__)
#define IDAS_TEST_UNDER_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define IDAS_TEST_UNDER_TSAN 1
#endif
#endif

#ifdef IDAS_TEST_UNDER_TSAN
#include <tbb/global_control.h>
#endif

int main(int argc, char** argv) {
#ifdef IDAS_TEST_UNDER_TSAN
    // Debian's libtbb is not instrumented, so ThreadSanitizer sees the work oneTBB hands to
    // its threads but not the joins, and reports every value a oneTBB task passes back (or
    // a heap block it used last). Under TSan, oneTBB's helpers (readers, checks, CGAL's
    // Delaunay) therefore run on the calling thread; the executor's workers are plain
    // std::threads (exec/workers.hpp), so races between operations are still seen.
    const tbb::global_control serial_helpers(tbb::global_control::max_allowed_parallelism, 1);
#endif
    return doctest::Context(argc, argv).run();
}
