# The 2D room benchmark's score and its classical peers (floor_plan_rooms.h), shared by rooms_eval and the tests:
# tests/ builds without bench/ (the asan and arm64 presets), so both include this fragment and the first defines it.
include_guard(GLOBAL)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs)
add_library(qsg_floor_plan_rooms ${CMAKE_CURRENT_LIST_DIR}/floor_plan_rooms.cc)
target_link_libraries(qsg_floor_plan_rooms PUBLIC qsg_world PRIVATE qsg_rooms opencv_core opencv_imgproc)
