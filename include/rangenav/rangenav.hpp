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
#include "rangenav/egocentric/floor.hpp"
#include "rangenav/egocentric/gaze.hpp"
#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/tof_obstacles.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/io/carmen.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/io/ply.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/registration/hayai.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/scan/pitching.hpp"
#include "rangenav/scan/tof_filters.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/world.hpp"
#include "rangenav/sim/world_file.hpp"
#include "rangenav/sim/worlds.hpp"
// clang-format on
