# Warning flags for rangenav's own tests, examples and benchmarks (never forced on users).
# -Werror is on when the cache option RANGENAV_WERROR is ON or the environment variable
# RANGENAV_WERROR is set to ON/1 (as CI does), so the README's presets stay usable with newer
# compilers that add warnings.
if(DEFINED ENV{RANGENAV_WERROR})
  set(_rangenav_werror_default $ENV{RANGENAV_WERROR})
else()
  set(_rangenav_werror_default OFF)
endif()
option(RANGENAV_WERROR "Treat warnings as errors" ${_rangenav_werror_default})

function(rangenav_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion)
  # Boost 1.74's own Boost.Geometry headers include a header it deprecates; keep that note (not a
  # warning, and nothing rangenav can change) out of our build logs.
  target_compile_definitions(${target} PRIVATE BOOST_ALLOW_DEPRECATED_HEADERS)
  if(RANGENAV_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
