#pragma once
// Includes every public header of rangenav. Handy for tutorials; a project that cares about
// compile time includes only the headers it uses. tests/check_umbrella.cmake keeps this list
// complete.

// clang-format off
#include "rangenav/control/indiveri_path_tracker.hpp"
#include "rangenav/control/indiveri_pose_controller.hpp"
#include "rangenav/control/local_frame_path.hpp"
#include "rangenav/control/motor_control.hpp"
#include "rangenav/control/reactive.hpp"
#include "rangenav/core/angles.hpp"
#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/carmen.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/io/pgm.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/planning/a_star.hpp"
#include "rangenav/planning/topological_map.hpp"
#include "rangenav/planning/voronoi_path_graph.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/scan/pitching.hpp"
#include "rangenav/sim/world.hpp"
#include "rangenav/sim/world_file.hpp"
// clang-format on
