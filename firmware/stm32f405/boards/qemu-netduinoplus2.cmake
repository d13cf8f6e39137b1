# Board: QEMU's netduinoplus2 machine (the emulator every qemu-arm test runs on). The image's
# behaviour before board files existed: an 8 MHz crystal value, CAN1 on PB8/PB9, USB OTG FS on
# PA11/PA12, console on USART1 TX PA9, no transceiver standby pin, no LED.
# QEMU models neither the crystal nor bxCAN nor OTG FS: the clock falls back as it does on a board
# whose crystal does not start, and the image runs its self-test (docs/stm32f405.md).
# Sources: QEMU's netduinoplus2 machine serial port is USART1 (qemu-run.sh reads the console there).
set(BOARD_TITLE "QEMU netduinoplus2 (emulator)")
set(BOARD_HSE_HZ 8000000)
set(BOARD_CAN_RX PB8)
set(BOARD_CAN_TX PB9)
set(BOARD_CAN_STANDBY "")
set(BOARD_CONSOLE USART1)
set(BOARD_CONSOLE_TX PA9)
set(BOARD_LED "")
