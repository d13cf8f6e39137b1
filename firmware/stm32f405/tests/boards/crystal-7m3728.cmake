# A board file the configure must refuse: a 7.3728 MHz crystal (a UART crystal) gives no exact
# 168 MHz / 48 MHz from the F405's PLL (tests: board.inexact-crystal-refused).
set(BOARD_TITLE "test: 7.3728 MHz crystal")
set(BOARD_HSE_HZ 7372800)
set(BOARD_CAN_RX PB8)
set(BOARD_CAN_TX PB9)
set(BOARD_CAN_STANDBY "")
set(BOARD_CONSOLE USART1)
set(BOARD_CONSOLE_TX PA9)
set(BOARD_LED "")
