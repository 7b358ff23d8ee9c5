# replica_bench: uploads through N ves-server replicas on PostgreSQL beside
# pgbench (docs/operations.md, "Scaling out"). Included from CMakeLists.txt.
add_executable(replica_bench ${CMAKE_CURRENT_LIST_DIR}/replica_bench.cc)
target_link_libraries(replica_bench PRIVATE ves::server ves::patient_db Boost::program_options)
target_compile_definitions(replica_bench PRIVATE VES_SERVER_PATH="$<TARGET_FILE:ves-server>"
  VES_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
add_dependencies(replica_bench ves-server)
ves_target_defaults(replica_bench)
