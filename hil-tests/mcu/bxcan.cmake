# hil-tests/mcu/bxcan.cmake: the bxCAN model (a library the emulator links) and its unit test, which
# drives the model with the driver's own filter plan and bit timing (firmware/stm32f405/logic).
# Included by hil-tests/mcu/CMakeLists.txt.
add_library(swell_mcu_bxcan STATIC ${CMAKE_CURRENT_LIST_DIR}/bxcan.c)
target_include_directories(swell_mcu_bxcan PUBLIC ${CMAKE_CURRENT_LIST_DIR})

set(bxcan_fw_logic ${CMAKE_CURRENT_LIST_DIR}/../../firmware/stm32f405/logic)
swell_catch_test(mcu_test_bxcan LABEL unit
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/tests/test_bxcan.cpp ${bxcan_fw_logic}/can_filter.c ${bxcan_fw_logic}/can_timing.c
  LIBS swell_mcu_bxcan swell_common)
target_include_directories(mcu_test_bxcan PRIVATE ${bxcan_fw_logic})
