# The USB OTG FS device model of the emulated STM32F405 (otgfs.c, RM0090 section 34) and its USB/IP
# server (usbip.c), with their unit tests (a driver scripted from the manual's programming model
# stands in for the image). Included by this directory's CMakeLists.txt; it needs no unicorn, so the
# include can come before that file's unicorn check.
add_library(swell_mcu_otgfs STATIC ${CMAKE_CURRENT_LIST_DIR}/otgfs.c ${CMAKE_CURRENT_LIST_DIR}/usbip.c)
target_include_directories(swell_mcu_otgfs PUBLIC ${CMAKE_CURRENT_LIST_DIR})

swell_catch_test(mcu_test_otgfs LABEL unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/tests/test_otgfs.cpp
                 LIBS swell_mcu_otgfs)
swell_catch_test(mcu_test_usbip LABEL unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/tests/test_usbip.cpp
                 LIBS swell_mcu_otgfs)

# The USB tunnel end to end (label mcu): the HIL VM imports the model through run-vm --usb-tunnel,
# swell-vm-usbip-bridge and vhci-hcd; swell-vm-usbtest echoes packets through it with libusb, also
# after an unplug and replug (the pull-up off for 3 s). This test's process is the USB/IP server,
# with the scripted driver where swell-mcu runs the image.
# A tree without the test programs (SWELL_TEST_PROGRAMS=OFF) has neither the program nor the test.
if(SWELL_TEST_PROGRAMS)
  add_executable(mcu_test_otgfs_vm ${CMAKE_CURRENT_LIST_DIR}/tests/test_otgfs_vm.cpp)
  target_link_libraries(mcu_test_otgfs_vm PRIVATE swell_mcu_otgfs Catch2::Catch2WithMain)
  set_target_properties(mcu_test_otgfs_vm PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  set(otgfs_vm_test "mcu: USB tunnel, the VM's Linux enumerates the OTG FS model over USB/IP (virtio-serial, vhci-hcd), swell-vm-usbtest echoes 300 packets of 1..64 bytes intact, and an unplug and replug of the device reach libusb")
  add_test(NAME "${otgfs_vm_test}" COMMAND mcu_test_otgfs_vm)
  set_tests_properties("${otgfs_vm_test}" PROPERTIES LABELS mcu FIXTURES_REQUIRED swell_vm_image RESOURCE_LOCK swell_vm TIMEOUT 400
    SKIP_RETURN_CODE 77 ENVIRONMENT
    "SWELL_RUN_VM=${PROJECT_SOURCE_DIR}/hil-tests/vm/run-vm;SWELL_VM_IMAGE=${CMAKE_BINARY_DIR}/vm;SWELL_VM_BIN=${CMAKE_BINARY_DIR}/bin")
endif()
