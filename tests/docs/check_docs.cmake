# Keeps README.md, CHANGELOG.md and docs/*.md honest (run by ctest; docs/getting_started.md,
# "How the documentation is tested", explains it to contributors):
#
#  1. Every C++ code block (```cpp) in them is preceded by a marker line
#       <!-- snippet: tests/docs/<file>.cpp#<name> -->
#     and is, character for character, the region of that file between the lines
#       // [snippet:<name>]      and      // [snippet-end]
#     with the marker's indentation removed. The files under tests/docs/ are compiled and run by
#     the test executable test_docs, so a snippet that no longer compiles or no longer does what
#     the text says fails a test, and a snippet edited only in the Markdown fails this check.
#  2. Every relative link ](path) points to a file or folder that exists.
#  3. No lab notebook: README.md, docs/ and include/ match neither "session N" nor "load N"
#     (history belongs in commit messages, CHANGELOG.md says what a user needs of it).
#
# Usage:  cmake -DROOT=<repository> -P tests/docs/check_docs.cmake               (check)
#         cmake -DROOT=<repository> -DUPDATE=ON -P tests/docs/check_docs.cmake   (rewrite the
#         Markdown's snippet blocks from the sources, then check)
cmake_minimum_required(VERSION 3.21)
if(NOT ROOT)
  set(ROOT "${CMAKE_CURRENT_LIST_DIR}/../..")
endif()
get_filename_component(ROOT "${ROOT}" ABSOLUTE)

set(errors "")
# Pages and files that other engineers are writing now; a link to one of them is reported, not
# failed, while it does not exist yet. Empty this list once they have landed.
set(pending_targets "")
set(pending_notes "")
macro(fail msg)
  string(APPEND errors "  ${msg}\n")
endmacro()

# The region `name` of `file` (relative to ROOT), dedented by its marker's indentation; sets
# `out` and `found`.
function(snippet_region file name out found)
  set(${found} FALSE PARENT_SCOPE)
  if(NOT EXISTS "${ROOT}/${file}")
    return()
  endif()
  file(READ "${ROOT}/${file}" text)
  string(FIND "${text}" "// [snippet:${name}]\n" begin)
  if(begin EQUAL -1)
    return()
  endif()
  # The marker's indentation: the spaces between the previous newline and the marker.
  string(SUBSTRING "${text}" 0 ${begin} before)
  string(FIND "${before}" "\n" line_start REVERSE)
  math(EXPR line_start "${line_start} + 1")
  math(EXPR indent_length "${begin} - ${line_start}")
  string(SUBSTRING "${text}" ${line_start} ${indent_length} indent)
  string(LENGTH "// [snippet:${name}]\n" marker_length)
  math(EXPR body_start "${begin} + ${marker_length}")
  string(SUBSTRING "${text}" ${body_start} -1 rest)
  string(FIND "${rest}" "// [snippet-end]" end)
  if(end EQUAL -1)
    return()
  endif()
  string(SUBSTRING "${rest}" 0 ${end} body)
  # Drop the end marker's own indentation (the body ends with "\n<indent>").
  string(FIND "${body}" "\n" last_newline REVERSE)
  if(last_newline EQUAL -1)
    set(body "")
  else()
    math(EXPR keep "${last_newline} + 1")
    string(SUBSTRING "${body}" 0 ${keep} body)
  endif()
  if(NOT indent STREQUAL "")
    set(body "\n${body}")
    string(REPLACE "\n${indent}" "\n" body "${body}")
    string(SUBSTRING "${body}" 1 -1 body)
  endif()
  set(${out} "${body}" PARENT_SCOPE)
  set(${found} TRUE PARENT_SCOPE)
endfunction()

file(GLOB markdown RELATIVE "${ROOT}" "${ROOT}/README.md" "${ROOT}/CHANGELOG.md"
     "${ROOT}/docs/*.md")
set(snippet_count 0)
set(link_count 0)
foreach(md IN LISTS markdown)
  file(READ "${ROOT}/${md}" text)
  get_filename_component(md_dir "${ROOT}/${md}" DIRECTORY)

  # ---- 1. snippets -----------------------------------------------------------------------
  set(rest "${text}")
  set(rebuilt "")
  set(line_no 1)
  while(TRUE)
    string(FIND "${rest}" "```cpp\n" fence)
    if(fence EQUAL -1)
      string(APPEND rebuilt "${rest}")
      break()
    endif()
    string(SUBSTRING "${rest}" 0 ${fence} head)
    string(REGEX MATCHALL "\n" newlines "${head}")
    list(LENGTH newlines n)
    math(EXPR line_no "${line_no} + ${n}")
    math(EXPR after_fence "${fence} + 7")
    string(SUBSTRING "${rest}" ${after_fence} -1 tail)
    string(FIND "${tail}" "```" close)
    if(close EQUAL -1)
      fail("${md}:${line_no}: unterminated ```cpp block")
      string(APPEND rebuilt "${rest}")
      break()
    endif()
    string(SUBSTRING "${tail}" 0 ${close} block)
    math(EXPR after_close "${close} + 3")
    string(SUBSTRING "${tail}" ${after_close} -1 rest)
    math(EXPR snippet_count "${snippet_count} + 1")
    if(head MATCHES "<!-- snippet: ([^#\n]+)#([A-Za-z0-9_.-]+) -->\n$")
      set(source "${CMAKE_MATCH_1}")
      set(name "${CMAKE_MATCH_2}")
      snippet_region("${source}" "${name}" expected found)
      if(NOT found)
        fail("${md}:${line_no}: ${source} has no region '// [snippet:${name}]' ... '// [snippet-end]'")
        set(expected "${block}")
      elseif(NOT block STREQUAL expected AND NOT UPDATE)
        fail("${md}:${line_no}: the block differs from ${source}#${name} (edit the source, then run `cmake -DROOT=. -DUPDATE=ON -P tests/docs/check_docs.cmake`)")
      endif()
      string(APPEND rebuilt "${head}```cpp\n${expected}```")
    else()
      fail("${md}:${line_no}: a ```cpp block without a '<!-- snippet: tests/docs/FILE.cpp#NAME -->' line before it (untested code)")
      string(APPEND rebuilt "${head}```cpp\n${block}```")
    endif()
  endwhile()
  if(UPDATE AND NOT rebuilt STREQUAL text)
    file(WRITE "${ROOT}/${md}" "${rebuilt}")
    message(STATUS "updated the snippets of ${md}")
  endif()

  # ---- 2. relative links -----------------------------------------------------------------
  # Code blocks may hold "](" in C++ (lambdas); links are looked for outside them only.
  string(REGEX REPLACE "```[^`]*```" "" prose "${text}")
  # Square brackets would stop CMake's lists from splitting: replace them first.
  string(REPLACE "[" "<LB>" prose "${prose}")
  string(REPLACE "]" "<RB>" prose "${prose}")
  string(REPLACE ";" "<SC>" prose "${prose}")
  string(REGEX MATCHALL "<RB>\\([^) \n]+\\)" links "${prose}")
  foreach(link IN LISTS links)
    string(REGEX REPLACE "^<RB>\\(([^)#]*)(#[^)]*)?\\)$" "\\1" target "${link}")
    if(target STREQUAL "" OR target MATCHES "^[a-z]+:")
      continue()
    endif()
    math(EXPR link_count "${link_count} + 1")
    if(NOT EXISTS "${md_dir}/${target}")
      get_filename_component(absolute "${md_dir}/${target}" ABSOLUTE)
      file(RELATIVE_PATH from_root "${ROOT}" "${absolute}")
      if(from_root IN_LIST pending_targets)
        string(APPEND pending_notes "  ${md}: ${target} (being written by its owner)\n")
      else()
        fail("${md}: broken link ${target}")
      endif()
    endif()
  endforeach()
endforeach()

# ---- 3. no lab notebook ------------------------------------------------------------------
file(GLOB_RECURSE user_facing RELATIVE "${ROOT}" "${ROOT}/docs/*.md" "${ROOT}/include/*.hpp")
list(APPEND user_facing README.md)
foreach(f IN LISTS user_facing)
  file(STRINGS "${ROOT}/${f}" hits REGEX "[Ss][Ee][Ss][Ss][Ii][Oo][Nn] [0-9]|[Ll][Oo][Aa][Dd] [0-9]")
  foreach(hit IN LISTS hits)
    fail("${f}: lab notebook in user-facing text: ${hit}")
  endforeach()
endforeach()

if(pending_notes)
  message(STATUS "links to pages not written yet:\n${pending_notes}")
endif()
if(errors)
  message(FATAL_ERROR "documentation check failed:\n${errors}")
endif()
message(STATUS "documentation: ${snippet_count} C++ snippets match tests/docs, ${link_count} relative links resolve, no lab notebook")
