# cmake -DGEN=swell-protogen -DOUT=dir -DSRC=docs -DPY=host/python/swell/_tables.py -P check_generated.cmake
# Regenerates protocol.md, parameters.md, swell.dbc and the Python package's tables into OUT and fails on
# any difference with the committed ones.
file(MAKE_DIRECTORY ${OUT})
execute_process(COMMAND ${GEN} --md ${OUT}/protocol.md --params ${OUT}/parameters.md --dbc ${OUT}/swell.dbc
                        --python ${OUT}/_tables.py RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "swell-protogen failed (${rc})")
endif()
foreach(f protocol.md parameters.md swell.dbc)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/${f} ${SRC}/${f} RESULT_VARIABLE diff)
  if(NOT diff EQUAL 0)
    message(FATAL_ERROR "docs/${f} differs from what the table generates (${OUT}/${f}): "
                        "run swell-protogen --md docs/protocol.md --params docs/parameters.md --dbc docs/swell.dbc and commit")
  endif()
  message(STATUS "docs/${f}: identical to the generated file")
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/_tables.py ${PY} RESULT_VARIABLE diff)
if(NOT diff EQUAL 0)
  message(FATAL_ERROR "host/python/swell/_tables.py differs from what the tables generate (${OUT}/_tables.py): "
                      "run swell-protogen --python host/python/swell/_tables.py and commit")
endif()
message(STATUS "host/python/swell/_tables.py: identical to the generated file")
