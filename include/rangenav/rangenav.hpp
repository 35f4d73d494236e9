#pragma once
// Includes every public header of rangenav. Handy for tutorials; a project that cares about
// compile time includes only the headers it uses. tests/check_umbrella.cmake keeps this list
// complete.

// clang-format off
#include "rangenav/core/angles.hpp"
#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/io/carmen.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"
#include "rangenav/mapping/key_frame.hpp"
#include "rangenav/mapping/sparse_point_map.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/frustum.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"
#include "rangenav/registration/rejectors.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/scan/pitching.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/world.hpp"
#include "rangenav/sim/world_file.hpp"
#include "rangenav/sim/worlds.hpp"
// clang-format on
