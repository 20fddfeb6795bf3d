# One function applies the language standard, warnings and sanitizers to every target of the project.
function(tandem_target target)
  target_compile_features(${target} PUBLIC cxx_std_17)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion -Wnon-virtual-dtor -Wold-style-cast)
  if(TANDEM_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(TANDEM_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
                                             -fno-sanitize-recover=undefined)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
  if(TANDEM_TSAN)
    target_compile_options(${target} PRIVATE -fsanitize=thread -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=thread)
  endif()
endfunction()

# Layers that point one way: fails the configuration if `target` reaches `forbidden` through its link
# libraries (direct or transitive). Called at the end of the top-level CMakeLists.txt, once every target exists.
function(tandem_forbid_dependency target forbidden)
  set(queue ${target})
  set(seen "")
  while(queue)
    list(POP_FRONT queue t)
    if(t IN_LIST seen)
      continue()
    endif()
    list(APPEND seen ${t})
    if(NOT TARGET ${t})
      continue()
    endif()
    get_target_property(real ${t} ALIASED_TARGET)
    if(real)
      set(t ${real})
    endif()
    set(deps "")
    get_target_property(type ${t} TYPE)
    if(NOT type STREQUAL "INTERFACE_LIBRARY")
      get_target_property(link ${t} LINK_LIBRARIES)
      if(link)
        list(APPEND deps ${link})
      endif()
    endif()
    get_target_property(ilink ${t} INTERFACE_LINK_LIBRARIES)
    if(ilink)
      list(APPEND deps ${ilink})
    endif()
    foreach(d IN LISTS deps)
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" d "${d}")
      if(d STREQUAL forbidden)
        message(FATAL_ERROR "layering: ${target} depends on ${forbidden} (through ${t}); docs/architecture.md, \"Layers\"")
      endif()
      list(APPEND queue ${d})
    endforeach()
  endwhile()
endfunction()

# A library of the C++ that protoc generates at build time (never committed) from idl/<name>.proto: target <target>,
# its headers on the include path of whoever links it.
function(tandem_proto_library target name)
  find_package(Protobuf REQUIRED)
  set(gen ${CMAKE_CURRENT_BINARY_DIR}/generated)
  set(src ${PROJECT_SOURCE_DIR}/idl/${name}.proto)
  add_custom_command(
    OUTPUT ${gen}/${name}.pb.cc ${gen}/${name}.pb.h
    COMMAND ${CMAKE_COMMAND} -E make_directory ${gen}
    COMMAND protobuf::protoc --cpp_out=${gen} -I ${PROJECT_SOURCE_DIR}/idl ${src}
    DEPENDS ${src} protobuf::protoc
    COMMENT "protoc: generating C++ from idl/${name}.proto"
    VERBATIM)
  add_library(${target} ${gen}/${name}.pb.cc)
  target_include_directories(${target} SYSTEM PUBLIC ${gen})
  target_link_libraries(${target} PUBLIC protobuf::libprotobuf)
  target_compile_features(${target} PUBLIC cxx_std_17)
endfunction()
