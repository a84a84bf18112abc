// What the module's translation units share: their binding functions, the exception that
// bad input raises, and how a run goes without the GIL.
#pragma once

#include "convert.hpp"

#include "tool/common.hpp"

#include <tbb/global_control.h>

#include <cstdint>
#include <string>

namespace idas::python {

void bind_io(py::module_& m);
void bind_surface_algorithms(py::module_& m);
void bind_tet_algorithms(py::module_& m);

/// Runs run(phases) without the GIL, with oneTBB on at most `threads` threads (as the tool
/// runs its reading, checks and writing), and returns what it returns.
template <class Run>
auto without_gil(unsigned threads, Run&& run) {
    py::gil_scoped_release nogil;
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
    tool::phase_times phases;
    return run(phases);
}

/// Refuses an empty face list or coordinates outside idas::geometry_range, as the tool
/// refuses such files.
void check_input_surface(const io::surface& s);

} // namespace idas::python
