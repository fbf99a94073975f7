# docs/parameters.md must be exactly the output of `pneumo params --markdown`, so that the
# documented MJCF keys are the ones the extension reads. Run by ctest (docs_parameters_match):
#   cmake -DPNEUMO=build/bin/pneumo -DDOC=docs/parameters.md -DOUT=build/parameters.md -P tests/check_parameters_doc.cmake
foreach(variable PNEUMO DOC OUT)
  if(NOT DEFINED ${variable})
    message(FATAL_ERROR "check_parameters_doc.cmake needs -D${variable}=...")
  endif()
endforeach()

execute_process(COMMAND ${PNEUMO} params --markdown
                OUTPUT_VARIABLE generated ERROR_VARIABLE error RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "`${PNEUMO} params --markdown` failed (${status}): ${error}")
endif()
if(NOT EXISTS ${DOC})
  message(FATAL_ERROR "${DOC} does not exist. Generate it from the source tree's root with:\n"
                      "  ${PNEUMO} params --markdown > docs/parameters.md")
endif()
file(READ ${DOC} documented)
if(NOT generated STREQUAL documented)
  file(WRITE ${OUT} "${generated}")
  message(FATAL_ERROR "${DOC} differs from the output of `pneumo params --markdown` (the MJCF keys changed?).\n"
                      "Compare:    diff -u ${DOC} ${OUT}\n"
                      "Regenerate, from the source tree's root:\n"
                      "  ${PNEUMO} params --markdown > docs/parameters.md")
endif()
