# Debian 12's OpenImageIO CMake package lists /usr/include/opencv4 among its include directories
# (OIIO was built with OpenCV support) although libopenimageio-dev does not depend on
# libopencv-dev. We use no OpenCV API, so drop the missing directory instead of installing
# OpenCV.
foreach(target OpenImageIO::OpenImageIO OpenImageIO::OpenImageIO_Util)
  if(TARGET ${target})
    foreach(property INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
      get_target_property(dirs ${target} ${property})
      if(dirs)
        list(FILTER dirs EXCLUDE REGEX "opencv4")
        set_target_properties(${target} PROPERTIES ${property} "${dirs}")
      endif()
    endforeach()
  endif()
endforeach()
