// A pixel's progressive photon-mapping estimate, shared by PPM/SPPM (progressive_photon) and
// MSPPM (msppm): what the eye paths saw themselves, averaged over the passes, plus the
// density estimate of the photon flux gathered within the pixel's radius.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/color.h"
#include "core/frame.h"

namespace gp {

// Thesis eq. 5.13 / 7.1: L = direct / passes + scale * tau / (N_e pi R^2), with N_e the photons
// emitted over all passes and scale = V_c (eq. 8.11) for adaptive photons, else 1. A pixel with
// no radius yet (R = 0) has no density estimate.
inline RGB progressive_radiance(const double (&direct)[3], const double (&tau)[3], double r2, int64_t passes,
                                int64_t emitted, double scale = 1.0) {
  if (passes <= 0) return RGB(0.0f);
  RGB L;
  for (int c = 0; c < 3; ++c) {
    double v = direct[c] / static_cast<double>(passes);
    if (r2 > 0 && emitted > 0) v += scale * tau[c] / (static_cast<double>(emitted) * M_PI * r2);
    L[c] = static_cast<float>(v);
  }
  return L;
}

// Which photons a measurement point gathers (PPM, SPPM, spectral photons, MSPPM, GPM's gather
// and its offsets), with wo towards the eye and wi towards where the photon came from, both in
// the point's frame: those on the side it is seen from, and where its BSDF transmits
// (Bsdf::transmits: rough glass, Translucent) those on the other side too, which light it
// through that lobe (f(wo, wi) of the transmission, radiance mode as every gather: photons
// carry the adjoint's flux, Veach 1997 §5.2). Issue 30: the far side was dropped everywhere, so
// SPPM saw rough glass at 0.01-0.2 of pt. An opaque surface keeps its one side: a photon on the
// far side of a thin wall lights nothing there and stays out of the count M.
inline bool photon_gather_side(bool transmits, const Vec3& wo, const Vec3& wi) {
  return transmits || same_hemisphere(wo, wi);
}

}  // namespace gp
