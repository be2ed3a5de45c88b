# The layering rule of docs/developing.md: the core and the communication layer know no
# physics, no output format and no application code (src/core, src/parallel include only
# each other), only src/physics/Registry.cpp names the concrete modules' kinds, and the two
# scenes' physics stay apart: src/physics/ring and src/physics/channel never include each other
# (both may use src/physics/contact and the generic modules in src/physics). io and app never
# look a module up by type, and app includes no module's header. The contact law's parameters
# stay in src/physics/contact.

# Fails when a line of one of `files` matches `regex`.
function(refuse files regex why)
  foreach(f ${files})
    file(STRINGS ${f} bad REGEX "${regex}")
    if(bad)
      message(FATAL_ERROR "${f} ${why}: ${bad}")
    endif()
  endforeach()
endfunction()

file(GLOB lower ${SRC}/core/* ${SRC}/parallel/*)
refuse("${lower}" "#include \"(physics|io|app|cg)/" "includes a higher layer")

file(GLOB_RECURSE all ${SRC}/*.cpp ${SRC}/*.hpp)
list(FILTER all EXCLUDE REGEX "physics/Registry.cpp$")
refuse("${all}" "[A-Za-z]+::kind\\(\\)," "lists module kinds; only src/physics/Registry.cpp may")

foreach(pair "ring;channel" "channel;ring")
  list(GET pair 0 from)
  list(GET pair 1 to)
  file(GLOB scene ${SRC}/physics/${from}/*)
  refuse("${scene}" "#include \"physics/${to}/" "includes the other scene's physics")
endforeach()

# Output and the application report through the Module interface (observables, results,
# contact_history, setup_report, ...), never by looking a concrete module up by type.
file(GLOB outer ${SRC}/io/* ${SRC}/app/*)
refuse("${outer}" "find<[A-Za-z]+>" "looks a module up by type (io and app go through the Module interface)")
# The application knows modules only through the registry (ModuleKind: read, make, prepare).
file(GLOB app ${SRC}/app/*)
refuse("${app}" "#include \"physics/" "includes a module's header (the app goes through core/ModuleRegistry.hpp)")
# The contact law's settings live beside the law (physics/contact/ContactSettings.hpp): the
# core, the communication layer, io and app name none of its parameters.
file(GLOB_RECURSE outside ${SRC}/core/* ${SRC}/parallel/* ${SRC}/io/* ${SRC}/app/*)
refuse("${outside}" "[^A-Za-z_](t_c|mu_s|mu_d|mu_r|v_c|youngs_modulus|kt_ratio|exact_contacts|clip_normal)[^A-Za-z_]"
       "names a contact-law parameter (they belong to physics/contact/ContactSettings.hpp)")
message(STATUS "layering: ok")
