#pragma once
// The memory estimate a scene is admitted with (io::memory_model): element counts per object,
// the contact units they predict, and the refusal of a scene that would not fit.
#include <string>
#include <vector>

#include "input.hpp"

namespace ccfr::io::scene {

/// Element counts of one object (or a whole scene), in doubles: products of 32-bit keys must not
/// wrap; and the contact units of io::memory_model.
struct Counts {
  double v = 0, f = 0, t = 0, e = 0;  ///< vertices, surface faces, tets, strand segments
  double sv = 0;                      ///< vertices that collide (a tet solid: its boundary's)
  double bv = 0, bf = 0;              ///< of those, the vertices and faces of rigid bodies and obstacles
  double driven = 0;                  ///< a surface moved by scripted pins, wound onto itself: sv (1 + D / h)²
  double strand = 0;                  ///< self-contact units of strands: sv (1 + D / h)
  double fine = 0;                    ///< a surface finer than D pairs with itself where flat: sv (D / h)²
  double grains = 0;                  ///< particles: how many others each has within D, summed
  double cross = 0;                   ///< contact with other objects (a deformable on either side)
  double patch = 0;                   ///< a rigid body's contact patch with another body
  double h = 0;                       ///< mean edge length of what collides (not summed)
  double rho = 0;                     ///< bodies: 3 volume / area of a closed surface; 0 if open (not summed)
  double area = 0;                    ///< collision surface area (strands: sv h²; not summed)
  Counts& operator+=(const Counts& o) {
    v += o.v, sv += o.sv, f += o.f, t += o.t, e += o.e, bv += o.bv, bf += o.bf;
    driven += o.driven, strand += o.strand, fine += o.fine, grains += o.grains, cross += o.cross, patch += o.patch;
    h = 0, rho = 0, area = 0;  // per object only
    return *this;
  }
};

inline bool is_body(ObjectKind k) { return k == ObjectKind::rigid || k == ObjectKind::obstacle; }

/// Marks the elements of a rigid body or an obstacle: they move as a whole, so they carry no
/// material constraints and never pair with each other.
inline Counts as_kind(Counts c, ObjectKind kind) {
  if (is_body(kind)) c.bv = c.v, c.bf = c.f, c.driven = c.strand = c.fine = 0;
  return c;
}

/// The objects placed so far, with their element counts (the refusal message lists them).
struct ObjectCost {
  std::string name;
  ObjectKind kind;
  Counts counts;
};

/// The scene's memory budget while its objects are read: each object's counts, checked against
/// the limit as they come, then the contact between objects once all are known.
class MemoryBudget {
 public:
  MemoryBudget(const Input& in, double max_memory_gb) : in_(in), max_memory_gb_(max_memory_gb) {}

  /// The detection reach D = 2r + ξ + δ: how far apart two primitives can be and still pair.
  static double reach(const SimulationParams& p);
  /// True if a pin group of `pins` (resolved) is moved by a script (see memory.cpp).
  static bool driven_by_pins(const YAML::Node& pins);
  /// Element counts of generated or loaded geometry, with its collision surface and its
  /// self-contact units for reach D.
  static Counts counts(const RawGeometry& g, ObjectKind kind, double reach, bool driven, double grain_cap);

  /// Fails when `add` (object `name`) does not fit 32-bit indices or the scene would need more
  /// memory than the limit.
  void check_size(const Counts& before, const Counts& add, const std::string& spath, const std::string& name,
                  ObjectKind kind) const;
  /// Records an object admitted with `counts`.
  void add(const std::string& name, ObjectKind kind, const Counts& counts) { costs_.push_back({name, kind, counts}); }
  /// Charges contact between objects, once every object is known.
  void charge_contact(Counts& total, double reach, double offset);
  /// The whole scene against the limit, once every object and its contact term are known.
  void check_total(const Counts& total) const { refuse_if_too_large(total, costs_, "objects"); }
  /// The bytes a scene may be estimated to need (0: unknown, no limit).
  double limit() const;
  const std::vector<ObjectCost>& costs() const { return costs_; }
  /// The estimate the scene was admitted with, per object.
  MemoryEstimate estimate() const;

 private:
  void refuse_if_too_large(const Counts& all, const std::vector<ObjectCost>& costs, const std::string& spath) const;
  static std::string cost_list(const std::vector<ObjectCost>& costs);

  const Input& in_;
  std::vector<ObjectCost> costs_;
  double max_memory_gb_ = 0;  ///< max_memory: 0 uses what the machine has available
  mutable double available_ = -1;
};

/// What the elements of one object (or of several: the sum is linear) add to the estimate.
double object_bytes(const Counts& c);
/// The whole estimate: the process base plus every object.
double estimate_bytes(const Counts& c);
/// A count without exponent.
std::string count_str(double n);
/// "12.3 GB", or "45 MB" below 1 GB.
std::string gigabytes(double b);

}  // namespace ccfr::io::scene
