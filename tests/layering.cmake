# The layering rule of docs/developing.md: the core and the communication layer know no
# physics, no output format and no application code (src/core, src/parallel include only
# each other), only src/physics/Registry.cpp names the concrete modules' kinds, and the two
# scenes' physics stay apart: src/physics/ring and src/physics/channel never include each other
# (both may use src/physics/contact and the generic modules in src/physics). io and app never
# look a module up by type.
file(GLOB lower ${SRC}/core/* ${SRC}/parallel/*)
foreach(f ${lower})
  file(STRINGS ${f} bad REGEX "#include \"(physics|io|app|cg)/")
  if(bad)
    message(FATAL_ERROR "${f} includes a higher layer: ${bad}")
  endif()
endforeach()
file(GLOB_RECURSE all ${SRC}/*.cpp ${SRC}/*.hpp)
foreach(f ${all})
  if(NOT f MATCHES "physics/Registry.cpp$")
    file(STRINGS ${f} named REGEX "[A-Za-z]+::kind\\(\\),")
    if(named)
      message(FATAL_ERROR "${f} lists module kinds; only src/physics/Registry.cpp may: ${named}")
    endif()
  endif()
endforeach()
foreach(pair "ring;channel" "channel;ring")
  list(GET pair 0 from)
  list(GET pair 1 to)
  file(GLOB scene ${SRC}/physics/${from}/*)
  foreach(f ${scene})
    file(STRINGS ${f} bad REGEX "#include \"physics/${to}/")
    if(bad)
      message(FATAL_ERROR "${f} includes the other scene's physics: ${bad}")
    endif()
  endforeach()
endforeach()
# Output and the application report through the Module interface (observables, results,
# contact_history, setup_report, ...), never by looking a concrete module up by type.
file(GLOB outer ${SRC}/io/* ${SRC}/app/*)
foreach(f ${outer})
  file(STRINGS ${f} typed REGEX "find<[A-Za-z]+>")
  if(typed)
    message(FATAL_ERROR "${f} looks a module up by type (io and app go through the Module interface): ${typed}")
  endif()
endforeach()
message(STATUS "layering: ok")
