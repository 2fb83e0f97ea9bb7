#pragma once
/// @file generators.hpp
/// Procedural meshes for scenes: cloth grids, strands, particle blocks, tet boxes and the
/// analytic obstacle shapes (sphere, cylinder, box, plane) as triangle meshes. y is up.
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr::gen {

struct TriMesh {
  Positions v;           ///< #V by 3
  std::vector<Vec3i> f;  ///< #F by 3, counter-clockwise seen from outside / from +normal
};
struct TetMesh {
  Positions v;
  std::vector<Vec4i> t;  ///< #T by 4, positive orientation
};
struct PolylineSet {
  Positions v;
  std::vector<std::vector<Index>> lines;
};

/// Rectangular cloth in the x-z plane centred at the origin, normal +y, `res` cells per side
/// ((res.x+1) (res.y+1) vertices), cells split along alternating diagonals.
TriMesh grid(double size_x, double size_z, Index res_x, Index res_z);
/// `count` straight strands of `vertices` vertices and length `length`, hanging along -y from
/// points spread on a square of side `spread` in the x-z plane (a single strand sits at the origin).
PolylineSet straight_strands(Index count, Index vertices, double length, double spread);
/// Helical ("curly") strands: like straight_strands but each is a helix of radius `coil_radius`
/// with `turns` turns around its -y axis. With `row`, the roots lie on one line along x instead of a square.
PolylineSet curly_strands(Index count, Index vertices, double length, double spread, double coil_radius, double turns,
                          bool row = false);
/// nx*ny*nz points on a regular lattice with `spacing`, centred at the origin.
Positions particle_block(Index nx, Index ny, Index nz, double spacing);
/// A box of `size` centred at the origin, `res` cells per axis, each cell split into 6 tets.
TetMesh tet_box(const Vec3& size, const Vec3i& res);
/// Icosphere of `radius`, `subdivisions` levels (0: icosahedron).
TriMesh sphere(double radius, int subdivisions);
/// Cylinder along y centred at the origin, `segments` around, optional caps.
TriMesh cylinder(double radius, double height, Index segments, bool capped);
/// Closed box of `size` centred at the origin (12 triangles), outward normals.
TriMesh box(const Vec3& size);
/// Open box (floor and four walls, no lid) of `size` whose floor is at y = -size.y/2, normals inward.
TriMesh open_box(const Vec3& size);
/// Square plane in the x-z plane, normal +y, split into res x res cells.
TriMesh plane(double size, Index res);

/// Tetrahedralises a union of lattice cells of edge `h` (cell (i,j,k) spans [i,i+1]h x ...): shared
/// corners are merged and every cell gets the same 6-tet Kuhn subdivision, which is conforming
/// across cells, so the result is one connected tet mesh per connected cell set.
TetMesh tet_voxels(const std::vector<Vec3i>& cells, double h);
/// An octopus-like solid (the paper does not give its mesh): a `body`^3 block of cells with
/// `legs` tentacles of `leg_length` cells that leave the bottom of the body outward and down,
/// tetrahedralised with tet_voxels; centred at the origin, body on top.
TetMesh octopus(double h, Index body, Index legs, Index leg_length);
/// A comb (the paper does not give its mesh): a spine box of `length` x `spine_height` x `width`
/// along x with `teeth` boxes hanging below it, each `tooth_length` long and `tooth_width` wide.
TriMesh comb(double length, double width, double spine_height, Index teeth, double tooth_length, double tooth_width);
/// Concatenates meshes (indices shifted).
TriMesh merge(const std::vector<TriMesh>& parts);

}  // namespace ccfr::gen
