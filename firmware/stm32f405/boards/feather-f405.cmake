# Board: Adafruit Feather STM32F405 Express (STM32F405RGT6) with an external 3.3 V CAN transceiver
# breakout whose standby (or silent) input is wired to pin D5; the Feather has no transceiver.
#   crystal   12 MHz HSE (PLL M 6, N 168, Q 7: 168 MHz and 48 MHz exactly)
#   CAN1      RX PB8 = Feather pin D9, TX PB9 = Feather pin D10, AF9 -> transceiver RXD / TXD
#   standby   PC7 = Feather pin D5 -> transceiver S / STB / Rs, driven low (normal mode) at start-up
#   USB       OTG FS PA11/PA12 on the USB-C connector (also the ROM DFU bootloader's port)
#   console   USART3 TX PB10 = Feather pin TX (D1), AF7, 115200 8N1, 3.3 V logic
#   LED       PC1 = the red LED by the USB connector (D13), lit when high
# Sources: MicroPython's board definition for this Feather (ports/stm32/boards/ADAFRUIT_F405_EXPRESS:
# "HSE is 12MHz", PLLM 12 / PLLN 336 / PLLQ 7, CAN1 TX pin_B9 "D10", RX pin_B8 "D9", UART3 TX pin_B10,
# LED1 pin_C1 red; pins.csv D5 = PC7, D9 = PB8, D10 = PB9, TX = PB10) and the STM32F405 datasheet's
# alternate-function table (AF9: PB8 CAN1_RX, PB9 CAN1_TX; AF7: PB10 USART3_TX). Adafruit's CAN guide
# for CircuitPython names D9 as TX and D10 as RX; the datasheet's table is the one the hardware
# follows: wire D10 (PB9) to the transceiver's TXD. Not checked on a board (docs/bringup-f405.md).
set(BOARD_TITLE "Adafruit Feather STM32F405 Express + CAN transceiver breakout")
set(BOARD_HSE_HZ 12000000)
set(BOARD_CAN_RX PB8)
set(BOARD_CAN_TX PB9)
set(BOARD_CAN_STANDBY PC7)
set(BOARD_CAN_STANDBY_NORMAL 0)
set(BOARD_CONSOLE USART3)
set(BOARD_CONSOLE_TX PB10)
set(BOARD_LED PC1)
set(BOARD_LED_ON 1)
