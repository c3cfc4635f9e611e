// The closed material set (DESIGN.md): diffuse, conductor, dielectric, emission-only.
// A Material is plain parameters; bsdf.h turns it into a BSDF evaluated in a local frame.
#pragma once

#include <string>
#include <vector>

#include "core/color.h"
#include "core/spectrum.h"

namespace gp {

enum class MaterialType { Diffuse, Conductor, Dielectric, Emission };

// Default roughness below which a BSDF counts as specular for photon methods
// (gradient-domain photon density estimation §4.3 / §6: "roughness threshold 0.05").
inline constexpr float kDefaultSpecularThreshold = 0.05f;

struct Material {
  std::string name;
  MaterialType type = MaterialType::Diffuse;
  // Diffuse: Lambertian albedo. Conductor: normal-incidence reflectance F0 (Schlick).
  // Dielectric: tint multiplying reflection and transmission (white = clear glass).
  RGB color{0.8f};
  // GGX alpha (Mitsuba's convention; Blender's roughness r maps to alpha = r^2).
  // 0 = perfectly smooth (delta) conductor or dielectric.
  float roughness = 0.0f;
  float ior = 1.5f;       // dielectric: interior IOR (Cauchy A) over an outside of 1
  float cauchy_b = 0.0f;  // Cauchy B in um^2: n(lambda) = A + B / lambda^2 (spectral mode)
  // Emitted radiance (W sr^-1 m^-2) = emission * strength; any type may emit.
  RGB emission{0.0f};
  float emission_strength = 0.0f;
  bool two_sided = false;  // emission from both faces; one-sided emits along the geometric normal
  // Line emission spectrum (scene format "spectrum"): empty = the smooth spectrum of `emission`.
  // When set, `emission` holds the lines' RGB at luminance 1 (spectral_lines_rgb), so
  // radiance() is the RGB-mode colour and strength the luminance.
  std::vector<SpectralLine> emission_lines;
  float emission_fwhm = 1.0f;  // nm

  RGB radiance() const { return emission * emission_strength; }
  bool is_emissive() const { return !radiance().is_black(); }
};

inline const char* to_string(MaterialType t) {
  switch (t) {
    case MaterialType::Diffuse: return "diffuse";
    case MaterialType::Conductor: return "conductor";
    case MaterialType::Dielectric: return "dielectric";
    case MaterialType::Emission: return "emission";
  }
  return "?";
}

}  // namespace gp
