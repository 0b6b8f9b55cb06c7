# OpenImageIO (Debian 12: libopenimageio-dev 2.4) as the imported target OpenImageIO::OpenImageIO.
# Debian's OpenImageIOConfig.cmake also imports the command-line tools (iconvert, oiiotool, ...) and
# stops with an error when the separate openimageio-tools package is absent, so the config is used
# only where those tools are installed; otherwise the library and headers are found directly.
find_program(SAHBENCH_OIIO_ICONVERT iconvert)
if(SAHBENCH_OIIO_ICONVERT)
  find_package(OpenImageIO CONFIG REQUIRED)
else()
  find_package(Imath CONFIG REQUIRED)  # OpenImageIO's public headers include Imath's
  find_path(SAHBENCH_OIIO_INCLUDE_DIR OpenImageIO/imageio.h REQUIRED)
  find_library(SAHBENCH_OIIO_LIBRARY OpenImageIO REQUIRED)
  find_library(SAHBENCH_OIIO_UTIL_LIBRARY OpenImageIO_Util REQUIRED)
  add_library(OpenImageIO::OpenImageIO UNKNOWN IMPORTED)
  set_target_properties(OpenImageIO::OpenImageIO PROPERTIES
    IMPORTED_LOCATION ${SAHBENCH_OIIO_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${SAHBENCH_OIIO_INCLUDE_DIR}
    INTERFACE_LINK_LIBRARIES "${SAHBENCH_OIIO_UTIL_LIBRARY};Imath::Imath")
endif()
