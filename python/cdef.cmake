# Turns the public header into the cffi declarations of the Python package (run with cmake -P at
# build time, so the package's declarations are the header's, never a hand-written copy):
#   cmake -DHEADER=sandmpm.h -DOUT=_cdef.h -DCC=cc -DSM_DOUBLE=0|1 -P cdef.cmake
# HEADER may be a list ("a.h;b.h"), concatenated in that order: the application layer's headers
# the package declares (_cdef_app.h, given to cffi after _cdef.h, whose types they use).
# The #include lines are dropped (cffi knows size_t and the <stdint.h> types), the rest goes through
# the C preprocessor with the build's precision, and the header's integer #defines (SM_MAX_...)
# are appended as "#define NAME value" lines, which cffi turns into constants.
foreach(v HEADER OUT CC SM_DOUBLE)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "cdef.cmake: -D${v}=... is required")
  endif()
endforeach()
set(text "")
set(names "")
foreach(h ${HEADER})
  file(READ ${h} one)
  string(APPEND text "${one}\n")
  get_filename_component(n ${h} NAME)
  list(APPEND names ${n})
endforeach()
string(REPLACE ";" ", " names "${names}")
string(REGEX REPLACE "(^|\n)[ \t]*#[ \t]*include[^\n]*" "\\1" text "${text}")
set(stripped ${OUT}.in.h)
file(WRITE ${stripped} "${text}")
execute_process(COMMAND ${CC} -E -P -DSM_DOUBLE=${SM_DOUBLE} ${stripped}
                OUTPUT_VARIABLE decls RESULT_VARIABLE rc ERROR_VARIABLE errs)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cdef.cmake: preprocessing ${HEADER} failed:\n${errs}")
endif()
execute_process(COMMAND ${CC} -E -dM -DSM_DOUBLE=${SM_DOUBLE} ${stripped}
                OUTPUT_VARIABLE macros RESULT_VARIABLE rc ERROR_VARIABLE errs)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cdef.cmake: listing the macros of ${HEADER} failed:\n${errs}")
endif()
string(REGEX MATCHALL "#define SM_[A-Z0-9_]+ [0-9]+" consts "${macros}")
list(SORT consts)
string(REPLACE ";" "\n" consts "${consts}")
file(REMOVE ${stripped})
# Blank lines left by the preprocessor are dropped to keep the file readable.
string(REGEX REPLACE "\n[ \t]*\n+" "\n" decls "${decls}")
file(WRITE ${OUT}.tmp "/* Generated from ${names} by python/cdef.cmake (SM_DOUBLE=${SM_DOUBLE}); do not edit. */\n${decls}\n${consts}\n")
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different ${OUT}.tmp ${OUT})
file(REMOVE ${OUT}.tmp)
