// Per-thread register files of compiled node graphs (graph.h) that keep a program's registers
// between its runs on a thread: a run writes only its ops' outputs, with no copy of the
// constants first (ShaderProgram::run copies every register in). Ops never write a constant
// register (folded ops are gone from the program; inputs are only read), and every node writes
// each of its read outputs on every run or on none (node_types.h NodeType::eval), so a run's
// values are run()'s.
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
