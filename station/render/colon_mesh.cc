#include "station/render/colon_mesh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "station/render/cecum_landmarks.h"

namespace ves::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

void Store(const Eigen::Vector3d& v, float out[3]) {
  out[0] = static_cast<float>(v.x());
  out[1] = static_cast<float>(v.y());
  out[2] = static_cast<float>(v.z());
}

Eigen::Vector3d Load(const float in[3]) { return Eigen::Vector3d(in[0], in[1], in[2]); }

}  // namespace

Eigen::Vector3d AnyPerpendicular(const Eigen::Vector3d& direction) {
  const Eigen::Vector3d d = direction.normalized();
  // Cross with the world axis least aligned with d: never degenerate.
  Eigen::Index axis = 0;
  d.cwiseAbs().minCoeff(&axis);
  return d.cross(Eigen::Vector3d::Unit(axis)).normalized();
}

double HaustralFoldFactor(const ColonMeshOptions& options, double arc_m, double angle_rad) {
  if (options.fold_depth <= 0.0 || options.fold_period_m <= 0.0) return 1.0;
  // A narrow ridge once per period: ((1 + cos)/2)^sharpness.
  const double ridge = std::pow(0.5 + 0.5 * std::cos(2.0 * kPi * arc_m / options.fold_period_m),
                                options.fold_sharpness);
  // Deepest between the three taeniae coli, shallower on them.
  const double around = 0.7 + 0.3 * std::cos(3.0 * angle_rad);
  return 1.0 - options.fold_depth * ridge * around;
}

void CalcMaterialArcs(const SceneGeometry& scene, std::vector<double>* arc_m) {
  if (!scene.colon_arc_m.empty()) {
    *arc_m = scene.colon_arc_m;
    return;
  }
  const size_t n = scene.colon_centers_m.size();
  arc_m->resize(n);
  double arc = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (i > 0) arc += (scene.colon_centers_m[i] - scene.colon_centers_m[i - 1]).norm();
    (*arc_m)[i] = arc;
  }
}

double CalcArcNear(const SceneGeometry& scene, const std::vector<double>& arc_m,
                   const Eigen::Vector3d& p_W) {
  const auto& centers = scene.colon_centers_m;
  size_t nearest = 0;
  double nearest_distance = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < centers.size(); ++i) {
    const double distance = (p_W - centers[i]).squaredNorm();
    if (distance < nearest_distance) {
      nearest_distance = distance;
      nearest = i;
    }
  }
  // Project on the segments on either side of the nearest ring centre.
  double best_arc = arc_m[nearest];
  double best_distance = std::numeric_limits<double>::infinity();
  for (size_t i = nearest == 0 ? 0 : nearest - 1; i <= nearest && i + 1 < centers.size(); ++i) {
    const Eigen::Vector3d segment = centers[i + 1] - centers[i];
    const double length2 = segment.squaredNorm();
    const double t =
        length2 > 0.0 ? std::clamp((p_W - centers[i]).dot(segment) / length2, 0.0, 1.0) : 0.0;
    const double distance = (p_W - (centers[i] + t * segment)).squaredNorm();
    if (distance < best_distance) {
      best_distance = distance;
      best_arc = arc_m[i] + t * (arc_m[i + 1] - arc_m[i]);
    }
  }
  return best_arc;
}

namespace {

// Step between mesh rings at arc distance `distance_m` from the tip: a
// power-of-two multiple of the finest step, so samples at multiples of it
// fall on one fixed grid of material arc length.
double RingStep(const ColonMeshOptions& options, double distance_m) {
  double step = options.ring_spacing_m;
  if (options.lod_distance_m <= 0.0) return step;
  for (double reach = options.lod_distance_m; distance_m >= reach - 1e-9; reach *= 2.0) {
    if (2.0 * step > options.max_ring_spacing_m) break;
    step *= 2.0;
  }
  return step;
}

// Two triangles per quad of the band between two rows of vertices (each
// sectors + 1 long, the seam duplicated), the tube's and the dome's alike.
void AppendQuadBand(std::uint32_t row, std::uint32_t next, int sectors,
                    std::vector<std::uint32_t>* triangles) {
  for (int j = 0; j < sectors; ++j) {
    const std::uint32_t a = row + j, b = a + 1, c = next + j, d = c + 1;
    triangles->insert(triangles->end(), {a, c, b, b, c, d});
  }
}

// The wireframe's loop round one row of vertices, and its lengthwise lines
// from a row to the next every `stride` sectors (the tube's and the dome's).
void AppendWireLoop(std::uint32_t row, int sectors, std::vector<std::uint32_t>* lines) {
  for (int j = 0; j < sectors; ++j) lines->insert(lines->end(), {row + j, row + j + 1});
}
void AppendWireMeridians(std::uint32_t row, std::uint32_t next, int sectors, int stride,
                         std::vector<std::uint32_t>* lines) {
  for (int j = 0; j < sectors; j += stride) lines->insert(lines->end(), {row + j, next + j});
}

// The cecum is a blind pouch: where the drawn window reaches the colon's
// last point, the tube is closed by a dome (half an ellipsoid) this deep,
// as a share of the last ring's radius, in this many rings of vertices. An
// open end showed the view at the cecum, the goal of the procedure, as a
// sharp black disc (the background behind the mesh). Rings enough for the
// appendiceal orifice at the pole and the triradiate fold (cecum_landmarks.h).
constexpr double kCecalPoleDepth = 0.6;
constexpr int kCecalPoleRings = 16;

// Appends the dome on the mesh's last ring: each vertex of that ring is
// carried toward the pole along a quarter ellipse (its folds and dents
// fading with it), so the dome meets the tube without a step. The dome's
// vertices take the last ring's model index and the
// texture runs on along the dome's meridians.
void AddCecalPole(const ColonMeshOptions& options, ColonMesh* mesh) {
  const int sectors = mesh->sectors;
  const int columns = sectors + 1;
  const size_t last = mesh->ring_centers_m.size() - 1;
  const Eigen::Vector3d& center = mesh->ring_centers_m[last];
  const Eigen::Vector3d& tangent = mesh->ring_tangents[last];
  const double mean_radius_m = mesh->ring_radius_m[last];  // between the folds
  const double depth_m = kCecalPoleDepth * mean_radius_m;
  if (!(depth_m > 0.0)) return;
  const auto rim = static_cast<std::uint32_t>(last * columns);
  const std::uint32_t first = static_cast<std::uint32_t>(mesh->vertices.size());
  mesh->vertices.resize(mesh->vertices.size() + kCecalPoleRings * columns);
  double meridian_m = 0.0;  // along the dome at the mean radius, for the texture
  for (int m = 1; m <= kCecalPoleRings; ++m) {
    const double phi = 0.5 * kPi * m / kCecalPoleRings;
    const double previous_phi = 0.5 * kPi * (m - 1) / kCecalPoleRings;
    meridian_m += std::hypot(mean_radius_m * (std::cos(previous_phi) - std::cos(phi)),
                             depth_m * (std::sin(phi) - std::sin(previous_phi)));
    for (int j = 0; j < columns; ++j) {
      const ColonVertex& base = mesh->vertices[rim + j];
      const Eigen::Vector3d out = Load(base.position_m) - center;  // in the ring's plane
      const double radius_m = out.norm();
      ColonVertex& v = mesh->vertices[first + (m - 1) * columns + j];
      // The ellipsoid's outward normal: (cos phi / a) a-direction + (sin phi / d) tangent.
      Eigen::Vector3d normal = std::sin(phi) / depth_m * tangent;
      if (radius_m > 1e-12) normal += std::cos(phi) / (radius_m * radius_m) * out;
      normal.normalize();
      // The cecum's landmarks raise the dome into the lumen (or sink it, the orifice).
      const double relief_m = options.cecum_landmarks
                                  ? CecalPoleRelief_m(phi, 2.0 * kPi * j / sectors, mean_radius_m)
                                  : 0.0;
      Store(center + std::cos(phi) * out + depth_m * std::sin(phi) * tangent - relief_m * normal,
            v.position_m);
      Store(normal, v.normal);
      v.uv[0] = base.uv[0];
      v.uv[1] = base.uv[1] + static_cast<float>(options.texture_length_m > 0.0
                                                    ? meridian_m / options.texture_length_m
                                                    : 0.0);
      v.ring = base.ring;
    }
  }
  // Normals by central differences, as the tube's (the landmarks' relief is
  // lit like the rest of the wall); the pole keeps the ellipsoid's.
  const auto row_of = [&](int m) { return m == 0 ? rim : first + (m - 1) * columns; };
  for (int m = 1; m < kCecalPoleRings; ++m) {
    for (int j = 0; j < columns; ++j) {
      const int j0 = (j + sectors - 1) % sectors;
      const int j1 = (j + 1) % sectors;
      const Eigen::Vector3d along = Load(mesh->vertices[row_of(m + 1) + j].position_m) -
                                    Load(mesh->vertices[row_of(m - 1) + j].position_m);
      const Eigen::Vector3d around = Load(mesh->vertices[row_of(m) + j1].position_m) -
                                     Load(mesh->vertices[row_of(m) + j0].position_m);
      const Eigen::Vector3d normal = around.cross(along);
      if (normal.norm() > 1e-12) Store(normal.normalized(), mesh->vertices[row_of(m) + j].normal);
    }
  }
  const int sector_stride = std::max(1, options.wire_sector_stride);
  for (int m = 0; m < kCecalPoleRings; ++m) {
    const std::uint32_t row = m == 0 ? rim : first + (m - 1) * columns;
    const std::uint32_t next = first + m * columns;
    AppendQuadBand(row, next, sectors, &mesh->triangles);
    // Wireframe: the dome's rings (not the pole itself, a point) and its meridians.
    if (m + 1 < kCecalPoleRings) AppendWireLoop(next, sectors, &mesh->lines);
    AppendWireMeridians(row, next, sectors, sector_stride, &mesh->lines);
  }
}

// The mesh's rings (ring_* of `mesh`): samples of material arc length in
// the window around the tip, on the LOD grid, each interpolated between the
// two model rings around it. Returns the window [start, end] drawn.
std::pair<double, double> PlaceMeshRings(const SceneGeometry& scene,
                                         const std::vector<double>& arc_m, double tip_arc_m,
                                         const ColonMeshOptions& options, ColonMesh* mesh) {
  const size_t n = scene.colon_centers_m.size();
  mesh->ring_centers_m.clear();
  mesh->ring_radius_m.clear();
  mesh->ring_tangents.clear();
  mesh->ring_index.clear();
  mesh->ring_arc_m.clear();
  auto effective_radius = [&](size_t k) {
    const double deformation = scene.wall_deformation_m.empty() ? 0.0 : scene.wall_deformation_m[k];
    return std::max(scene.colon_radius_m[k] - deformation,
                    options.min_radius_fraction * scene.colon_radius_m[k]);
  };
  const double first_arc = arc_m.front();
  const double last_arc = arc_m.back();
  const bool windowed = options.ahead_m > 0.0;
  const double start = windowed ? std::max(first_arc, tip_arc_m - options.behind_m) : first_arc;
  const double end = windowed ? std::min(last_arc, tip_arc_m + options.ahead_m) : last_arc;
  const double finest = std::max(options.ring_spacing_m, 1e-4);
  size_t segment = 0;
  auto add_ring = [&](double s) {
    while (segment + 2 < n && arc_m[segment + 1] <= s) ++segment;
    const double span = arc_m[segment + 1] - arc_m[segment];
    const double t = span > 0.0 ? std::clamp((s - arc_m[segment]) / span, 0.0, 1.0) : 0.0;
    const Eigen::Vector3d& a = scene.colon_centers_m[segment];
    const Eigen::Vector3d& b = scene.colon_centers_m[segment + 1];
    mesh->ring_centers_m.push_back(a + t * (b - a));
    Eigen::Vector3d tangent = (1.0 - t) * scene.colon_tangents[segment].normalized() +
                              t * scene.colon_tangents[segment + 1].normalized();
    if (tangent.norm() < 1e-9) tangent = b - a;
    if (tangent.norm() < 1e-12) tangent = Eigen::Vector3d::UnitZ();
    mesh->ring_tangents.push_back(tangent.normalized());
    mesh->ring_radius_m.push_back((1.0 - t) * effective_radius(segment) +
                                  t * effective_radius(segment + 1));
    mesh->ring_index.push_back(static_cast<double>(segment) + t);
    mesh->ring_arc_m.push_back(s);
  };
  if (end > start) {
    add_ring(start);
    double s = start;
    while (true) {
      const double step = std::max(finest, RingStep(options, std::abs(s - tip_arc_m)));
      // The tolerance keeps a sample that rounding put just below a grid
      // point from producing that grid point again.
      const double next = (std::floor(s / step + 1e-6) + 1.0) * step;
      if (next >= end - 1e-9) break;
      add_ring(next);
      s = next;
    }
    add_ring(end);
  } else {
    add_ring(start);
    add_ring(std::min(last_arc, start + finest));
  }
  return {start, end};
}

// The vertices on the mesh's rings: a parallel-transported frame, folds,
// dents, the cecum's valve, texture coordinates. `last_arc` is the colon's
// last point (the cecal pole). Marks in `on_valve` the vertices on the
// ileocaecal valve (the wireframe's dense patch).
void PlaceVertices(const SceneGeometry& scene, const ColonMeshOptions& options, double last_arc,
                   ColonMesh* mesh, std::vector<bool>* on_valve) {
  const size_t n = scene.colon_centers_m.size();
  const int sectors = mesh->sectors;
  const std::vector<double>& arc = mesh->ring_arc_m;
  std::vector<std::pair<Eigen::Vector3d, double>> dents;
  const size_t rings = mesh->ring_centers_m.size();
  const int columns = sectors + 1;
  mesh->vertices.resize(rings * columns);
  Eigen::Vector3d normal_axis = AnyPerpendicular(mesh->ring_tangents[0]);
  // The ileocaecal valve sits on the cecum's medial wall: the side facing
  // the middle of the colon's frame (cecum_landmarks.h).
  Eigen::Vector3d colon_middle = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& c : scene.colon_centers_m) colon_middle += c;
  colon_middle /= static_cast<double>(n);
  on_valve->assign(rings * columns, false);
  for (size_t k = 0; k < rings; ++k) {
    const Eigen::Vector3d& t = mesh->ring_tangents[k];
    normal_axis -= normal_axis.dot(t) * t;
    normal_axis = normal_axis.norm() > 1e-6 ? normal_axis.normalized() : AnyPerpendicular(t);
    const Eigen::Vector3d binormal_axis = t.cross(normal_axis);
    // Dents near this ring, as (direction in the ring's plane, depth here).
    dents.clear();
    for (const WallDent& dent : scene.wall_dents) {
      const double along = (arc[k] - dent.arc_m) / std::max(options.dent_spread_m, 1e-6);
      if (std::abs(along) > 3.0 || dent.depth_m == 0.0) continue;
      const Eigen::Vector3d in_plane = dent.direction_W - dent.direction_W.dot(t) * t;
      if (in_plane.norm() < 1e-9) continue;
      dents.emplace_back(in_plane.normalized(), dent.depth_m * std::exp(-along * along));
    }
    const double from_pole_m = last_arc - arc[k];
    const bool at_valve = options.cecum_landmarks && from_pole_m < kValveReach_m;
    const Eigen::Vector3d medial = colon_middle - mesh->ring_centers_m[k];
    const double medial_angle = std::atan2(medial.dot(binormal_axis), medial.dot(normal_axis));
    for (int j = 0; j < columns; ++j) {
      const double angle = 2.0 * kPi * j / sectors;
      const Eigen::Vector3d radial =
          std::cos(angle) * normal_axis + std::sin(angle) * binormal_axis;
      double radius = mesh->ring_radius_m[k] * HaustralFoldFactor(options, arc[k], angle);
      if (at_valve) {
        radius *= IleocaecalValveFactor(from_pole_m, angle - medial_angle);
        (*on_valve)[k * columns + j] = OnIleocaecalValve(from_pole_m, angle - medial_angle);
      }
      for (const auto& [direction, depth_m] : dents) {
        const double c = std::max(0.0, radial.dot(direction));
        radius += depth_m * c * c * c * c;
      }
      const Eigen::Vector3d p = mesh->ring_centers_m[k] + radius * radial;
      ColonVertex& v = mesh->vertices[k * columns + j];
      Store(p, v.position_m);
      v.uv[0] = static_cast<float>(static_cast<double>(j) / sectors);
      v.uv[1] = static_cast<float>(options.texture_length_m > 0 ? arc[k] / options.texture_length_m
                                                                : 0.0);
      v.ring = static_cast<float>(mesh->ring_index[k]);
    }
  }
}

// Normals by central differences over the grid (sign is irrelevant:
// the shaders turn them toward the light at the tip).
void CalcGridNormals(ColonMesh* mesh) {
  const int sectors = mesh->sectors;
  const size_t rings = mesh->ring_centers_m.size();
  const int columns = sectors + 1;
  for (size_t k = 0; k < rings; ++k) {
    const size_t k0 = k == 0 ? 0 : k - 1;
    const size_t k1 = std::min(k + 1, rings - 1);
    for (int j = 0; j < columns; ++j) {
      const int j0 = (j + sectors - 1) % sectors;
      const int j1 = (j + 1) % sectors;
      const Eigen::Vector3d along = Load(mesh->vertices[k1 * columns + j].position_m) -
                                    Load(mesh->vertices[k0 * columns + j].position_m);
      const Eigen::Vector3d around = Load(mesh->vertices[k * columns + j1].position_m) -
                                     Load(mesh->vertices[k * columns + j0].position_m);
      Eigen::Vector3d normal = around.cross(along);
      normal = normal.norm() > 1e-12 ? normal.normalized() : Eigen::Vector3d::UnitZ();
      Store(normal, mesh->vertices[k * columns + j].normal);
    }
  }
}

// Topology: two triangles per quad; wireframe loops and lengthwise lines,
// every ring and sector on the ileocaecal valve.
void BuildTopology(const ColonMeshOptions& options, const std::vector<bool>& on_valve,
                   bool closes_cecum, ColonMesh* mesh) {
  const int sectors = mesh->sectors;
  const size_t rings = mesh->ring_centers_m.size();
  const int columns = sectors + 1;
  const std::vector<double>& arc = mesh->ring_arc_m;
  mesh->triangles.clear();
  mesh->lines.clear();
  mesh->triangles.reserve((rings - 1 + (closes_cecum ? kCecalPoleRings : 0)) * sectors * 6);
  for (size_t k = 0; k + 1 < rings; ++k) {
    const auto row = static_cast<std::uint32_t>(k * columns);
    AppendQuadBand(row, row + static_cast<std::uint32_t>(columns), sectors, &mesh->triangles);
  }
  const int sector_stride = std::max(1, options.wire_sector_stride);
  for (size_t k = 0; k < rings; ++k) {
    const auto base = static_cast<std::uint32_t>(k * columns);
    // Loops at fixed material arc (multiples of wire_ring_spacing_m), so
    // they move with the tissue, not with the tip.
    const double wire_phase =
        options.wire_ring_spacing_m > 0.0 ? arc[k] / options.wire_ring_spacing_m : 0.0;
    if (std::abs(wire_phase - std::round(wire_phase)) < 1e-6) {
      AppendWireLoop(base, sectors, &mesh->lines);
    }
    if (k + 1 < rings) {
      AppendWireMeridians(base, base + static_cast<std::uint32_t>(columns), sectors, sector_stride,
                          &mesh->lines);
    }
    // On the ileocaecal valve every ring and sector, so its lips show.
    const auto next = base + static_cast<std::uint32_t>(columns);
    for (int j = 0; j < sectors; ++j) {
      if (!on_valve[base + j]) continue;
      if (on_valve[base + j + 1]) mesh->lines.insert(mesh->lines.end(), {base + j, base + j + 1});
      if (k + 1 < rings && j % sector_stride != 0 && on_valve[next + j]) {
        mesh->lines.insert(mesh->lines.end(), {base + j, next + j});
      }
    }
  }
}

}  // namespace

void BuildColonMesh(const SceneGeometry& scene, const std::vector<double>& arc_m, double tip_arc_m,
                    const ColonMeshOptions& options, ColonMesh* mesh) {
  mesh->sectors = std::max(3, options.sectors);
  const auto [start, end] = PlaceMeshRings(scene, arc_m, tip_arc_m, options, mesh);
  std::vector<bool> on_valve;
  PlaceVertices(scene, options, arc_m.back(), mesh, &on_valve);
  CalcGridNormals(mesh);
  // The cecum's closed end, when the window reaches it.
  const bool closes_cecum = end >= arc_m.back() - 1e-9 && end > start;
  BuildTopology(options, on_valve, closes_cecum, mesh);
  if (closes_cecum) AddCecalPole(options, mesh);
}

void BuildTubeMesh(const std::vector<Eigen::Vector3d>& points_m, double radius_m, int sectors,
                   std::vector<float>* positions_m, std::vector<std::uint32_t>* triangles) {
  positions_m->clear();
  triangles->clear();
  if (points_m.size() < 2) return;
  sectors = std::max(3, sectors);
  Eigen::Vector3d normal_axis = AnyPerpendicular(points_m[1] - points_m[0]);
  for (size_t k = 0; k < points_m.size(); ++k) {
    const size_t k0 = k == 0 ? 0 : k - 1;
    const size_t k1 = std::min(k + 1, points_m.size() - 1);
    Eigen::Vector3d t = points_m[k1] - points_m[k0];
    t = t.norm() > 1e-12 ? t.normalized() : Eigen::Vector3d::UnitZ();
    normal_axis -= normal_axis.dot(t) * t;
    normal_axis = normal_axis.norm() > 1e-6 ? normal_axis.normalized() : AnyPerpendicular(t);
    const Eigen::Vector3d binormal_axis = t.cross(normal_axis);
    for (int j = 0; j < sectors; ++j) {
      const double angle = 2.0 * kPi * j / sectors;
      const Eigen::Vector3d p = points_m[k] + radius_m * (std::cos(angle) * normal_axis +
                                                          std::sin(angle) * binormal_axis);
      positions_m->insert(positions_m->end(), {static_cast<float>(p.x()), static_cast<float>(p.y()),
                                               static_cast<float>(p.z())});
    }
  }
  for (size_t k = 0; k + 1 < points_m.size(); ++k) {
    for (int j = 0; j < sectors; ++j) {
      const auto a = static_cast<std::uint32_t>(k * sectors + j);
      const auto b = static_cast<std::uint32_t>(k * sectors + (j + 1) % sectors);
      const auto c = a + static_cast<std::uint32_t>(sectors);
      const auto d = b + static_cast<std::uint32_t>(sectors);
      triangles->insert(triangles->end(), {a, c, b, b, c, d});
    }
  }
}

}  // namespace ves::render
