# `penumbra compare`: its two tests, each on its own line with its verdict, and
# exit status 3 when either fails (README, "compare"). The bound on the means
# is the user's --max-rel-diff, never widened by the images' noise.
file(MAKE_DIRECTORY ${WORK})
set(SIZE --backend cpu --width 64 --height 36)
function(render name)
  execute_process(COMMAND ${PENUMBRA} render cornell-sphere ${SIZE} ${ARGN} -o ${WORK}/${name}.exr
                  --variance ${WORK}/${name}_var.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "render ${name} failed (${rc}):\n${err}")
  endif()
endfunction()
# compare A B STATUS LINE1 LINE2 LINE3 [options...]: the exit status, and each of the three lines begins so.
function(compare a b status first statistical bound)
  execute_process(COMMAND ${PENUMBRA} compare ${WORK}/${a}.exr ${WORK}/${a}_var.exr ${WORK}/${b}.exr
                          ${WORK}/${b}_var.exr ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL ${status})
    message(FATAL_ERROR "compare ${a} ${b} ${ARGN}: exit status ${rc}, expected ${status}\n${out}${err}")
  endif()
  string(REGEX REPLACE "\n$" "" out "${out}")
  string(REPLACE "\n" ";" lines "${out}")
  list(LENGTH lines n)
  if(NOT n EQUAL 3)
    message(FATAL_ERROR "compare ${a} ${b} ${ARGN}: expected 3 lines, got ${n}:\n${out}")
  endif()
  set(i 0)
  set(OUT "${out}" PARENT_SCOPE)
  foreach(expect "${WORK}/${a}.exr vs ${WORK}/${b}.exr: ${first}" "  statistical test: ${statistical}"
                 "  bound on the means ${bound}")
    list(GET lines ${i} line)
    string(FIND "${line}" "${expect}" pos)
    if(NOT pos EQUAL 0)
      message(FATAL_ERROR "compare ${a} ${b} ${ARGN}: line ${i} does not begin with '${expect}':\n${out}")
    endif()
    math(EXPR i "${i} + 1")
  endforeach()
endfunction()

# The verdicts below hold for any unbiased renderer (they do not depend on the exact numbers): independent seeds
# differ by a few standard errors at most, a 10% brighter light by many.
render(s1 --spp 16 --seed 1)
render(s2 --spp 16 --seed 2)
# The statistical test cannot tell independent seeds apart; a bound of 0 can, and decides: exit 3.
compare(s1 s2 3 "FAIL: means" "PASS: image means within 4 standard errors" "(--max-rel-diff 0%): FAIL: they differ by"
        --max-rel-diff 0)
# The bound line repeats the first line's relative difference and gives the standard error of the difference.
string(REGEX MATCH "rel. diff ([0-9.]+)%" _ "${OUT}")
set(diff ${CMAKE_MATCH_1})
if(NOT OUT MATCHES "FAIL: they differ by ${diff}%, more than that \\(standard error of the difference: [0-9.]+%\\)")
  message(FATAL_ERROR "the bound's line does not give the difference ${diff}% and its standard error:\n${OUT}")
endif()
# The report of issue 32: a tight bound was silently widened to 4 standard errors and printed PASS.
compare(s1 s2 3 "FAIL: means" "PASS:" "(--max-rel-diff 0.01%): FAIL:" --max-rel-diff 0.0001)
# A bound the noise cannot reach leaves the verdict to the statistical test.
compare(s1 s2 0 "PASS: means" "PASS:" "(--max-rel-diff 100%): PASS: they differ by" --max-rel-diff 1)
# An image against itself: equal means pass even a bound of 0.
compare(s1 s1 0 "PASS: means" "PASS:" "(--max-rel-diff 0%): PASS: they differ by 0.000%" --max-rel-diff 0)
# A light 10% brighter, at 256 spp: within a 20% bound, but the statistical test sees it: exit 3.
render(bright --spp 256 --seed 3 --set "light.power=[86.79,73.59,37.73]")
render(s4 --spp 256 --seed 4)
compare(bright s4 3 "FAIL: means" "FAIL: image means not within 4 standard errors" "(--max-rel-diff 20%): PASS:"
        --max-rel-diff 0.2)
# The default bound, 1%, as the first line says.
compare(bright s4 3 "FAIL: means" "FAIL:" "(--max-rel-diff 1%): FAIL:")
