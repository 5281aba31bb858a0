# Renderer benchmark (included by bench/CMakeLists.txt): frames/s of the simulated RGB-D camera on one core.
if(TARGET qsg_render)
  add_executable(bm_renderer ${CMAKE_CURRENT_LIST_DIR}/bm_renderer.cc)
  target_link_libraries(bm_renderer PRIVATE qsg_render qsg_bench_main)
  # The self-contained building always runs; drivers/world's generated building too when that library exists.
  option(QSG_BENCH_RENDER_GENERATED "Also benchmark the renderer on world::generate_building" ON)
  if(QSG_BENCH_RENDER_GENERATED AND TARGET qsg_world)
    target_link_libraries(bm_renderer PRIVATE qsg_world)
    target_compile_definitions(bm_renderer PRIVATE QSG_BENCH_RENDER_WITH_GENERATOR=1)
  endif()
endif()
