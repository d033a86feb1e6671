# Run as `cmake -DHEADERS=a.hpp;b.hpp -P lcm_bound_lengths.cmake` on headers written by lcm-gen 1.3.1 --cpp.
# Rewrites each decoder so that no declared length allocates more than the datagram can hold:
#  - a string's length (which counts its terminating NUL) must be at least 1 and fit in the remaining bytes;
#  - an array count read from the message must be 0 or more and at most the remaining bytes (every element
#    takes at least one byte), checked before the vector is resized.
# Fails the build if a header does not have the shape this expects, so a new lcm-gen cannot silently bypass it.
# Fails unless `text` holds as many matches of `guarded` as of `all`.
function(expect_all_bounded text all guarded what)
  string(REGEX MATCHALL "${all}" all_matches "${text}")
  string(REGEX MATCHALL "${guarded}" guarded_matches "${text}")
  list(LENGTH all_matches n_all)
  list(LENGTH guarded_matches n_guarded)
  if(NOT n_all EQUAL n_guarded)
    message(FATAL_ERROR "lcm_bound_lengths: ${header}: ${n_guarded} of ${n_all} ${what} bounded")
  endif()
endfunction()

foreach(header ${HEADERS})
  file(READ ${header} text)
  if(NOT text MATCHES "_decodeNoHash")
    message(FATAL_ERROR "lcm_bound_lengths: ${header} has no _decodeNoHash: not an lcm-gen C++ header?")
  endif()
  # string lengths: `if(__name_len__ > maxlen - pos) return -1;` and `if(__elem_len > maxlen - pos) return -1;`
  string(REGEX REPLACE "if\\((__[A-Za-z_0-9]+) > maxlen - pos\\) return -1;"
                       "if(\\1 < 1 || \\1 > maxlen - pos) return -1;" text "${text}")
  # array counts: `this->member.resize(this->count);` and `this->member[a0].resize(this->count);`
  string(REGEX REPLACE "([ ]*)(this->[A-Za-z_0-9]+(\\[a[0-9]+\\])*\\.resize\\(this->([A-Za-z_0-9]+)\\);)"
                       "\\1if(this->\\4 < 0 || this->\\4 > maxlen - pos) return -1;\n\\1\\2" text "${text}")
  # Every string assign and every resize from a message field must now be guarded (counted on a copy without
  # semicolons, which would split CMake's lists).
  string(REPLACE ";" ":" flat "${text}")
  expect_all_bounded("${flat}" "\\.resize\\(this->"
                     "> maxlen - pos\\) return -1:\n[ ]*this->[A-Za-z_0-9]+(\\[a[0-9]+\\])*\\.resize\\(this->" "array counts")
  expect_all_bounded("${flat}" "_len_* > maxlen - pos" "< 1 \\|\\| __[A-Za-z_0-9]+ > maxlen - pos" "string lengths")
  file(WRITE ${header} "${text}")
endforeach()
