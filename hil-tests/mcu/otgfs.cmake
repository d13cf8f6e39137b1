# The USB OTG FS device model of the emulated STM32F405 (otgfs.c, RM0090 section 34) and its USB/IP
# server (usbip.c), with their unit tests (a driver scripted from the manual's programming model
# stands in for the image). Included by this directory's CMakeLists.txt.
add_library(swell_mcu_otgfs STATIC ${CMAKE_CURRENT_LIST_DIR}/otgfs.c ${CMAKE_CURRENT_LIST_DIR}/usbip.c)
target_include_directories(swell_mcu_otgfs PUBLIC ${CMAKE_CURRENT_LIST_DIR})

swell_catch_test(mcu_test_otgfs LABEL unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/tests/test_otgfs.cpp
                 LIBS swell_mcu_otgfs)
swell_catch_test(mcu_test_usbip LABEL unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/tests/test_usbip.cpp
                 LIBS swell_mcu_otgfs)
