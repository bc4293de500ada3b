# Project warning set (STYLE.md) and the sanitizer switch.
function(sq_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wstrict-prototypes -Wmissing-prototypes
    -Wdouble-promotion -Wfloat-conversion -Wvla -Wno-overlength-strings)
  if(SQ_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

if(SQ_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer -O1 -g)
  add_link_options(-fsanitize=address,undefined)
endif()

# Tests mix float and double freely in checks; keep everything else strict.
function(sq_set_test_warnings target)
  sq_set_warnings(${target})
  target_compile_options(${target} PRIVATE -Wno-double-promotion -Wno-float-conversion
                         -Wno-missing-prototypes)
endfunction()
