# Board definitions of the STM32F405 image: swell_board_header(NAME_OR_FILE OUT_HEADER) reads
# boards/NAME.cmake (or a board file given by path), checks it and writes the C header the image is
# built with (SWELL_BOARD_* and the PLL factors). Every refusal is a configure-time FATAL_ERROR that
# says what is wrong and what would be accepted. A board file sets:
#   BOARD_TITLE                 what the board is
#   BOARD_HSE_HZ                crystal, Hz: some PLL setting must give 168 MHz and 48 MHz exactly
#   BOARD_CAN_RX, BOARD_CAN_TX  CAN1 pins, AF9: PA11/PA12, PB8/PB9 or PD0/PD1
#   BOARD_CAN_STANDBY           "" or the pin wired to the transceiver's standby/silent input;
#   BOARD_CAN_STANDBY_NORMAL    the level it is driven to for normal mode (0 or 1)
#   BOARD_CONSOLE, _TX          USART1 PA9|PB6, USART2 PA2|PD5, USART3 PB10|PC10|PD8 (AF7), USART6 PC6 (AF8)
#   BOARD_LED, BOARD_LED_ON     "" or the status LED's pin and the level that lights it
# USB OTG FS has no choice on the F405: PA11 DM, PA12 DP, AF10.

cmake_policy(SET CMP0057 NEW)
set(SWELL_BOARD_DIR ${CMAKE_CURRENT_LIST_DIR})

function(swell_board_pin var pin what)
  if(NOT pin MATCHES "^P([A-I])([0-9]|1[0-5])$")
    message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: ${what} '${pin}' is not a pin (PA0 .. PI15)")
  endif()
  string(FIND "ABCDEFGHI" "${CMAKE_MATCH_1}" port)
  set(${var}_PORT ${port} PARENT_SCOPE)
  set(${var}_PIN ${CMAKE_MATCH_2} PARENT_SCOPE)
endfunction()

# The F405's PLL: VCO input HSE/M in 0.95 .. 2.1 MHz (M 2..63), VCO = input x N (N 50..432) in
# 100 .. 432 MHz, SYSCLK = VCO / 2, USB 48 MHz = VCO / Q (Q 2..15). 168 MHz and 48 MHz exactly need a
# VCO of 336 MHz and Q 7: HSE x N = 336 MHz x M. The largest VCO input (least jitter) is chosen.
function(swell_board_pll hse out_m out_n)
  foreach(m RANGE 2 63)
    math(EXPR in_khz "${hse} / ${m} / 1000")
    if(in_khz GREATER 2100 OR in_khz LESS 950)
      continue()
    endif()
    math(EXPR num "336000000 * ${m}")
    math(EXPR n "${num} / ${hse}")
    math(EXPR back "${n} * ${hse}")
    if(back EQUAL num AND n GREATER_EQUAL 50 AND n LESS_EQUAL 432)
      set(${out_m} ${m} PARENT_SCOPE)
      set(${out_n} ${n} PARENT_SCOPE)
      return()
    endif()
  endforeach()
  set(${out_m} "" PARENT_SCOPE)
endfunction()

function(swell_board_header board out)
  if(EXISTS "${board}" AND NOT IS_DIRECTORY "${board}")
    set(file "${board}")
  elseif(board MATCHES "^[a-z0-9-]+$" AND EXISTS "${SWELL_BOARD_DIR}/${board}.cmake")
    set(file "${SWELL_BOARD_DIR}/${board}.cmake")
  else()
    file(GLOB known RELATIVE ${SWELL_BOARD_DIR} ${SWELL_BOARD_DIR}/*.cmake)
    list(REMOVE_ITEM known board.cmake)
    list(TRANSFORM known REPLACE "\\.cmake$" "")
    list(JOIN known ", " known)
    message(FATAL_ERROR "SWELL_BOARD=${board}: unknown board (known: ${known}; or the path of a board "
                        "file, see firmware/stm32f405/boards/board.cmake and docs/bringup-f405.md)")
  endif()
  get_filename_component(SWELL_BOARD_FILE_NAME "${file}" NAME_WE)
  foreach(v TITLE HSE_HZ CAN_RX CAN_TX CAN_STANDBY CAN_STANDBY_NORMAL CONSOLE CONSOLE_TX LED LED_ON)
    unset(BOARD_${v})
  endforeach()
  include("${file}")
  foreach(v TITLE HSE_HZ CAN_RX CAN_TX CONSOLE CONSOLE_TX)
    if(NOT DEFINED BOARD_${v} OR "${BOARD_${v}}" STREQUAL "")
      message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: BOARD_${v} is not set")
    endif()
  endforeach()

  if(NOT BOARD_HSE_HZ MATCHES "^[0-9]+$" OR BOARD_HSE_HZ LESS 4000000 OR BOARD_HSE_HZ GREATER 26000000)
    message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: crystal ${BOARD_HSE_HZ} Hz: the F405's HSE "
                        "oscillator takes 4 to 26 MHz")
  endif()
  swell_board_pll(${BOARD_HSE_HZ} pll_m pll_n)
  if(NOT pll_m)
    message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: crystal ${BOARD_HSE_HZ} Hz: no exact 168/48 MHz "
                        "(HSE x N must equal 336 MHz x M with HSE/M in 0.95..2.1 MHz): use a crystal such "
                        "as 8, 12, 16 or 25 MHz")
  endif()

  set(can "${BOARD_CAN_RX}/${BOARD_CAN_TX}")
  if(NOT can MATCHES "^(PA11/PA12|PB8/PB9|PD0/PD1)$")
    message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: CAN1 RX/TX ${can} is not a CAN1 pin pair "
                        "(RX/TX: PA11/PA12, PB8/PB9 or PD0/PD1)")
  endif()
  if(can STREQUAL "PA11/PA12")
    message(WARNING "board ${SWELL_BOARD_FILE_NAME}: CAN1 on PA11/PA12 takes the USB pins: use CAN only")
  endif()
  swell_board_pin(CAN_RX ${BOARD_CAN_RX} "CAN RX")
  swell_board_pin(CAN_TX ${BOARD_CAN_TX} "CAN TX")

  set(con "${BOARD_CONSOLE}:${BOARD_CONSOLE_TX}")
  if(con MATCHES "^USART1:(PA9|PB6)$")
    set(con_n 1)
    set(con_af 7)
  elseif(con MATCHES "^USART2:(PA2|PD5)$")
    set(con_n 2)
    set(con_af 7)
  elseif(con MATCHES "^USART3:(PB10|PC10|PD8)$")
    set(con_n 3)
    set(con_af 7)
  elseif(con MATCHES "^USART6:PC6$")
    set(con_n 6)
    set(con_af 8)
  else()
    message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: console ${BOARD_CONSOLE} TX ${BOARD_CONSOLE_TX} "
                        "is not a USART TX pin (USART1 PA9|PB6, USART2 PA2|PD5, USART3 PB10|PC10|PD8, "
                        "USART6 PC6)")
  endif()
  swell_board_pin(CON_TX ${BOARD_CONSOLE_TX} "console TX")

  set(used "${BOARD_CAN_RX};${BOARD_CAN_TX};${BOARD_CONSOLE_TX}")
  set(stby "#define SWELL_BOARD_STBY 0")
  if(NOT "${BOARD_CAN_STANDBY}" STREQUAL "")
    swell_board_pin(STBY ${BOARD_CAN_STANDBY} "CAN standby")
    if(NOT "${BOARD_CAN_STANDBY_NORMAL}" MATCHES "^[01]$")
      message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: BOARD_CAN_STANDBY_NORMAL must be 0 or 1")
    endif()
    list(APPEND used ${BOARD_CAN_STANDBY})
    set(stby "#define SWELL_BOARD_STBY 1\n#define SWELL_BOARD_STBY_PORT ${STBY_PORT}u\n"
             "#define SWELL_BOARD_STBY_PIN ${STBY_PIN}u\n#define SWELL_BOARD_STBY_NORMAL ${BOARD_CAN_STANDBY_NORMAL}u")
    string(JOIN "" stby ${stby})
  endif()
  set(led "#define SWELL_BOARD_LED 0")
  if(NOT "${BOARD_LED}" STREQUAL "")
    swell_board_pin(LED ${BOARD_LED} "LED")
    if(NOT "${BOARD_LED_ON}" MATCHES "^[01]$")
      message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: BOARD_LED_ON must be 0 or 1")
    endif()
    list(APPEND used ${BOARD_LED})
    set(led "#define SWELL_BOARD_LED 1\n#define SWELL_BOARD_LED_PORT ${LED_PORT}u\n"
            "#define SWELL_BOARD_LED_PIN ${LED_PIN}u\n#define SWELL_BOARD_LED_ON ${BOARD_LED_ON}u")
    string(JOIN "" led ${led})
  endif()
  if(NOT can STREQUAL "PA11/PA12")
    list(APPEND used PA11 PA12)
  endif()
  set(seen "")
  foreach(p ${used})
    if(p IN_LIST seen)
      message(FATAL_ERROR "board ${SWELL_BOARD_FILE_NAME}: pin ${p} is given two jobs (CAN, USB PA11/PA12, "
                          "console, standby, LED)")
    endif()
    list(APPEND seen ${p})
  endforeach()

  file(CONFIGURE OUTPUT "${out}" CONTENT "/* Generated from firmware/stm32f405/boards/${SWELL_BOARD_FILE_NAME}.cmake by
 * boards/board.cmake at configure time: do not edit. */
#ifndef SWELL_BOARD_CONFIG_H
#define SWELL_BOARD_CONFIG_H

#define SWELL_BOARD_NAME \"${SWELL_BOARD_FILE_NAME}\"
#define SWELL_HSE_HZ ${BOARD_HSE_HZ}u
#define SWELL_PLL_M ${pll_m}u /* VCO input HSE / M */
#define SWELL_PLL_N ${pll_n}u /* VCO 336 MHz; SYSCLK VCO / 2 = 168 MHz; USB VCO / 7 = 48 MHz */
#define SWELL_BOARD_CAN_RX_PORT ${CAN_RX_PORT}u
#define SWELL_BOARD_CAN_RX_PIN ${CAN_RX_PIN}u
#define SWELL_BOARD_CAN_TX_PORT ${CAN_TX_PORT}u
#define SWELL_BOARD_CAN_TX_PIN ${CAN_TX_PIN}u
${stby}
#define SWELL_BOARD_CON_USART ${con_n}
#define SWELL_BOARD_CON_TX_PORT ${CON_TX_PORT}u
#define SWELL_BOARD_CON_TX_PIN ${CON_TX_PIN}u
#define SWELL_BOARD_CON_TX_AF ${con_af}u
${led}

#endif
" @ONLY)
  set(SWELL_BOARD_SUMMARY "${SWELL_BOARD_FILE_NAME}: ${BOARD_TITLE}; HSE ${BOARD_HSE_HZ} Hz (PLL M ${pll_m} N ${pll_n} Q 7), CAN1 RX ${BOARD_CAN_RX} TX ${BOARD_CAN_TX}, console ${BOARD_CONSOLE} TX ${BOARD_CONSOLE_TX}" PARENT_SCOPE)
endfunction()

# Script mode (cmake -DSWELL_BOARD=... -DOUT=... -P board.cmake): check a board and write its header.
if(CMAKE_SCRIPT_MODE_FILE STREQUAL CMAKE_CURRENT_LIST_FILE)
  if(NOT DEFINED OUT)
    set(OUT /dev/null)
  endif()
  swell_board_header("${SWELL_BOARD}" "${OUT}")
  message(STATUS "board ${SWELL_BOARD_SUMMARY}")
endif()
