// `gradphoton merge`: combine independent-seed runs of one render into one image (DESIGN.md,
// "Beyond one machine"). Each run's EXR carries its RunInfo (distributed/run_info.h); runs of
// another scene, image size, method, method parameters or pass set are refused with an error
// naming the file, as are repeated seeds (the same seed renders the same image: not independent).
//
// Every run is weighted by the work it did, w_i = paths_i / sum paths (camera paths, photons
// or mutations, as each method counts them in Stats::paths). Per pass:
//   - by default the weighted mean (the estimate of one run with all the samples, for every
//     method whose pass is a per-sample mean: pt, spt, spt-hero, and sgpt, whose per-pixel
//     spectral reconstruction is linear, L2, so reconstructing the merged bins = merging);
//   - gradient methods (gpt, gpm, gdmlt): primal and gradients are merged, then `combined` is
//     reconstructed once by the method's own screened Poisson solve (its recon and lambda,
//     integrators/gradient/gradient_passes.h); L1 is not linear, so averaging reconstructed
//     images would be wrong;
//   - counts (photon_count, sample_density) are summed; spectral_gradient (an RMS) is the
//     root of the weighted mean square;
//   - error (relative bound on luminance): photon methods' bound holds a bias term that
//     averaging does not reduce, so the merged absolute bound is the weighted mean of the
//     runs' (conservative); for unbiased methods it is the root sum of squares of the weighted
//     absolute errors.
// Photon methods (ppm, sppm, sppm-adaptive, msppm, gpm): averaging N runs of K passes divides
// the variance by N but keeps the bias of K passes (the radius shrinks with each run's own
// passes); one run of N K passes has less bias. Merged is still consistent as K grows.
#pragma once

#include <string>
#include <vector>

#include "core/film.h"
#include "distributed/run_info.h"

namespace gp {

struct MergeInput {
  std::string path;  // for messages
  Film film;
  RunInfo run;
};

struct MergeResult {
  Film film;
  RunInfo run;                        // seeds, runs, passes, paths and seconds summed
  std::vector<std::string> warnings;  // e.g. runs of different gradphoton versions
};

// True for methods whose merged estimate keeps the bias of one run (photon density estimation).
bool merge_keeps_bias(const std::string& method);

// Reads every file (read_exr, read_exr_attributes) and merges them. Throws std::runtime_error
// naming the file at fault.
MergeResult merge_files(const std::vector<std::string>& paths, int threads = 0);
MergeResult merge_runs(const std::vector<MergeInput>& runs, int threads = 0);

}  // namespace gp
