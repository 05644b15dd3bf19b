# Writes OUTPUT, a C++ file defining `const char* polyhex::FUNCTION()` that returns the text of INPUT.
#   cmake -DINPUT=file -DOUTPUT=file.cpp -DFUNCTION=name -P embed_text.cmake
# The text goes into a raw string literal: it must not contain `)polyhex_embed"`.
file(READ "${INPUT}" text)
string(FIND "${text}" ")polyhex_embed\"" bad)
if(NOT bad EQUAL -1)
  message(FATAL_ERROR "${INPUT} contains the raw-string delimiter )polyhex_embed\"")
endif()
file(WRITE "${OUTPUT}.tmp" "// Generated from ${INPUT} by cmake/embed_text.cmake: edit that file, not this one.\n"
  "namespace polyhex {\nconst char* ${FUNCTION}() {\n  return R\"polyhex_embed(${text})polyhex_embed\";\n}\n}  // namespace polyhex\n")
file(RENAME "${OUTPUT}.tmp" "${OUTPUT}")
