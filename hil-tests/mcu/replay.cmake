# hil-tests/mcu/replay.cmake: the emulated STM32F405's deterministic replay (mcu_replay.c: a recorded
# bus fed into CAN1 tick by tick, the frames the image sends logged with their virtual time, bus
# faults at virtual times), swell-mcu-replay, and the tests on the product image (label mcu):
# docs/stm32f405-emulator.md, "Scenarios and the force identity". Included by this directory's
# CMakeLists.txt after swell_mcu.
add_library(swell_mcu_replay STATIC ${CMAKE_CURRENT_LIST_DIR}/mcu_replay.c)
target_include_directories(swell_mcu_replay PUBLIC ${CMAKE_CURRENT_LIST_DIR})
target_link_libraries(swell_mcu_replay PUBLIC swell_mcu)
add_executable(swell-mcu-replay ${CMAKE_CURRENT_LIST_DIR}/mcu_replay_main.c)
target_link_libraries(swell-mcu-replay PRIVATE swell_mcu_replay swell_common_host)

set(mcu_image ${SWELL_BENCH_BIN_DIR}/../firmware/stm32f405/image/swell-fw.elf)
set(mcu_work ${CMAKE_BINARY_DIR}/hil-tests/mcu/out)

# Scripts that import the swell package (numpy) run under Debian's python3, as the python label does
# (another python3 first on PATH may lack Debian's numpy).
if(SWELL_DEBIAN_PYTHON3)
  set(mcu_py ${SWELL_DEBIAN_PYTHON3})
else()
  set(mcu_py python3)
endif()

# The force identity: one drop recorded from swell-hm, replayed to swell-ctl (--clock device, UDP) and
# to the image in the emulator (CAN1), gives the same FORCE_CMD payload at every tick.
set(mcu_identity "mcu: one recorded drop gives swell-ctl and the emulated STM32F405 image bit-identical FORCE_CMD payloads at every one of 3000 ticks")
add_test(NAME "${mcu_identity}"
  COMMAND sh -c "[ -f \"$1\" ] || { echo \"no image $1: build swell_fw_image\"; exit 77; }; shift; exec \"$@\""
          sh ${mcu_image} ${mcu_py} ${CMAKE_CURRENT_LIST_DIR}/tests/force-identity run --bin ${SWELL_BENCH_BIN_DIR}
          --image ${mcu_image} --work ${mcu_work}/identity --seconds 3 --hand drop:z=20,hold=0.2)
set_tests_properties("${mcu_identity}" PROPERTIES LABELS mcu TIMEOUT 240 SKIP_RETURN_CODE 77
  PASS_REGULAR_EXPRESSION "OK: 3000 ticks compared, FORCE_CMD payloads bit-identical")

# The CAN fault paths on the real driver: bus-off, no ACK, every TX mailbox full, transmit errors, a
# stuck bus and an RX FIFO overrun, each injected into the bxCAN model at a virtual time while the
# image holds the object; the image's force record and the commands a device would render are judged.
set(mcu_faults "mcu: CAN faults on the image's driver (bus-off, no ACK, TX mailboxes full, transmit errors, stuck bus): the image zeroes its force within 5 ticks, the device within 2, both recover; an RX overrun loses no tick")
add_test(NAME "${mcu_faults}" COMMAND ${mcu_py} ${CMAKE_CURRENT_LIST_DIR}/tests/can-faults ${SWELL_BENCH_BIN_DIR} ${mcu_image}
                                      ${mcu_work}/can-faults)
set_tests_properties("${mcu_faults}" PROPERTIES LABELS mcu TIMEOUT 240 SKIP_RETURN_CODE 77
  PASS_REGULAR_EXPRESSION "can-faults: OK")

# A USB unplug with the image's device link on USB (--no-can): swell-mcu's USB tunnel in lockstep (the
# script, a USB/IP host playing the device, clocks virtual time: deterministic), the session's end is the
# cable out, the next session the cable in (--usb-replug); swell-mcu's --usb-log is judged.
set(mcu_unplug "mcu: USB unplug with the image's device link on USB: its force zero within 2 ticks of its driver seeing the suspend, no stale FORCE_CMD after the replug, the weight commanded again within 150 ms of the new configuration")
add_test(NAME "${mcu_unplug}" COMMAND ${mcu_py} ${CMAKE_CURRENT_LIST_DIR}/tests/usb-unplug ${SWELL_BENCH_BIN_DIR}/swell-mcu
                                      ${mcu_image} ${mcu_work}/usb-unplug)
set_tests_properties("${mcu_unplug}" PROPERTIES LABELS mcu TIMEOUT 120 SKIP_RETURN_CODE 77
  PASS_REGULAR_EXPRESSION "usb-unplug: OK")

# HIL scenarios with the image as the controller (run-scenario, topology f405-can): one VM boot
# (fixture swell_vm_image of hil-tests/vm), the image on swell-mcu for the whole boot, paced by the
# device's samples; the scenario files' own criteria. About 100 s of wall time on 2 cores.
# flood@f405-can: a third node floods the shared bus for a wall second (1100-10800 frames/s in the VM);
# the device model takes only its own messages (an acceptance filter), swell-mcu's tunnel takes the
# peer's frames by arbitration and drops the least urgent from a full queue, and swell-vm-canbridge
# never waits on the line (docs/hil-bench.md).
# f405-usb: the image with no CAN (device and host on USB, 2500 Hz) behind the USB tunnel, in a boot
# of its own (an idle second swell-mcu beside the first would take CPU from the VM on 2 cores);
# usb-replug pulls the cable in the VM. About 190 s (2500 Hz in lockstep: 2 ms of wall time a tick).
if(EXISTS ${PROJECT_SOURCE_DIR}/hil-tests/vm/run-vm)
  foreach(place can usb)
    if(place STREQUAL can)
      set(runs drop shake linkloss busoff params estop flood)
      set(where "on the VM's CAN bus")
    else()
      set(runs drop shake linkloss estop usb-replug)
      set(where "on the VM's USB (vhci-hcd through the USB tunnel)")
    endif()
    list(LENGTH runs n)
    string(REPLACE ";" ", " names "${runs}")
    list(TRANSFORM runs APPEND "@f405-${place}")
    set(mcu_scn "mcu: the product image on swell-mcu as the controller of the HIL scenarios ${where} (f405-${place}, one boot): ${names} pass their criteria")
    add_test(NAME "${mcu_scn}"
      COMMAND sh -c "[ -f \"$1\" ] || { echo \"no image $1: build swell_fw_image\"; exit 77; }; shift; exec \"$@\""
              sh ${mcu_image} ${PROJECT_SOURCE_DIR}/hil-tests/bench/run-scenario --place vm --bin ${SWELL_BENCH_BIN_DIR}
              --image ${CMAKE_BINARY_DIR}/vm --f405 ${mcu_image} --out ${mcu_work}/f405-${place} --timeout 900 ${runs})
    set_tests_properties("${mcu_scn}" PROPERTIES LABELS mcu FIXTURES_REQUIRED swell_vm_image RESOURCE_LOCK swell_vm TIMEOUT 960
      SKIP_RETURN_CODE 77 PASS_REGULAR_EXPRESSION "run-scenario: PASS, ${n} scenario")
  endforeach()
endif()
