# What this build has and what it left out. Every optional dependency is looked
# up quietly, so without this summary a missing package went unnoticed until a
# feature failed at run time; here each part left out names the package that
# adds it.
#
#   vpffd_feature(<name> ON  "<what it gives>")
#   vpffd_feature(<name> OFF "<what is missing>" "<what to install>")
#   vpffd_feature_summary()   # once, at the end of the top-level CMakeLists.txt
# The texts must not contain ";" or "|" (entries are stored as CMake lists).

function(vpffd_feature name state what)
  if(state)
    set_property(GLOBAL APPEND PROPERTY VPFFD_FEATURES_FOUND "${name}|${what}")
  else()
    set_property(GLOBAL APPEND PROPERTY VPFFD_FEATURES_MISSING "${name}|${what}. To add it: ${ARGV3}, then configure again")
  endif()
endfunction()

# An option set to OFF by the user is reported as such, not as a missing package.
function(vpffd_feature_disabled name option)
  set_property(GLOBAL APPEND PROPERTY VPFFD_FEATURES_MISSING "${name}|turned off (-D${option}=OFF)")
endfunction()

function(vpffd_feature_summary)
  get_property(_found GLOBAL PROPERTY VPFFD_FEATURES_FOUND)
  get_property(_missing GLOBAL PROPERTY VPFFD_FEATURES_MISSING)
  message(STATUS "vpffd ${PROJECT_VERSION}: configuration summary")
  if(NOT _found)
    message(STATUS "  built with: nothing optional")
  else()
    message(STATUS "  built with:")
  endif()
  foreach(_entry IN LISTS _found)
    string(REPLACE "|" ";" _parts "${_entry}")
    list(GET _parts 0 _name)
    list(GET _parts 1 _what)
    message(STATUS "    ${_name}: ${_what}")
  endforeach()
  if(NOT _missing)
    message(STATUS "  left out: nothing")
    return()
  endif()
  message(STATUS "  left out:")
  foreach(_entry IN LISTS _missing)
    string(REPLACE "|" ";" _parts "${_entry}")
    list(GET _parts 0 _name)
    list(GET _parts 1 _what)
    message(STATUS "    ${_name}: ${_what}")
  endforeach()
endfunction()
