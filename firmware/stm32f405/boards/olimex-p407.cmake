# Board: Olimex STM32-P407 (STM32F407ZGT6, the F405 with Ethernet and more pins: the same core,
# bxCAN, OTG FS and device id 0x413, so the F405 image runs on it) with its on-board CAN transceiver.
#   crystal   25 MHz HSE (PLL M 25, N 336, Q 7: 168 MHz and 48 MHz exactly)
#   CAN1      RX PB8, TX PB9, AF9, to the on-board transceiver
#   standby   none driven by swell (not in the sources below: if the board's schematic puts the
#             transceiver's mode pin on a GPIO, give it as BOARD_CAN_STANDBY)
#   USB       OTG FS PA11/PA12 on the USB-OTG connector
#   console   USART3 TX PD8, AF7, 115200 8N1 (the USART NuttX uses on this board; through the
#             board's RS232 driver if it has one: check the schematic before wiring 3.3 V logic)
#   LED       PF6 = LED1 (green), lit when high
# Sources: NuttX's board support for this board (configs/olimex-stm32-p407: "On-board crystal frequency
# is 25MHz", PLLM 25 / PLLN 336 / PLLQ 7, GPIO_CAN1_RX PB8, GPIO_CAN1_TX PB9, USART3 TX PD8 / RX PD9,
# LED1 PF6 push-pull); Olimex's support forum (topic 7885: "We have included CAN option with level
# transceiver in ... STM32-P407 ... We have used PB8 and PB9"); the STM32F405/407 datasheet's
# alternate-function table (AF9 CAN1, AF7 USART3). Not checked on a board (docs/bringup-f405.md).
set(BOARD_TITLE "Olimex STM32-P407 (on-board CAN transceiver)")
set(BOARD_HSE_HZ 25000000)
set(BOARD_CAN_RX PB8)
set(BOARD_CAN_TX PB9)
set(BOARD_CAN_STANDBY "")
set(BOARD_CONSOLE USART3)
set(BOARD_CONSOLE_TX PD8)
set(BOARD_LED PF6)
set(BOARD_LED_ON 1)
