// Per-thread register files of compiled node graphs (graph.h) that keep a program's constants
// between its runs on a thread: a run then sets back only the registers ops write (their
// outputs, a few) to their initial values, where ShaderProgram::run copies every register in
// (the constants are most of them). Ops never write a constant register (folded ops are gone from
// the program; inputs are only read), so the file starts each run as run()'s does.
#pragma once

#include <memory>

#include "shading/graph.h"

namespace gp::shading {

// Runs `program` at `ctx` in this thread's register file for it and returns the registers
// (ShaderProgram::num_registers() of them), valid until the next call on this thread: a few
// programs' files are kept per thread, the oldest replaced by a program without one (it then
// copies its constants once). Counted by ShaderProgram::runs_on_this_thread() as run().
const Vec3* run_in_thread_registers(const std::shared_ptr<const ShaderProgram>& program, const ShadingContext& ctx);

}  // namespace gp::shading
