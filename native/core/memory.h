// How much memory a scene or an image may fill before loading it is refused with a clear error
// (docs/reliability.md): a few bytes of JSON can ask for a 100 M-triangle torus, a few bytes of
// EXR header for a 1 M x 1 M image.
#pragma once

namespace gp {

// GRADPHOTON_MEMORY_LIMIT_MB when set (cluster nodes, the fuzzers), else what the kernel reports
// as available (MemAvailable); 0 when neither is known (no limit).
double memory_budget_bytes();

}  // namespace gp
