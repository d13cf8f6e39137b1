@ fault_probe.s: the fault probe of test_cpu.cpp (its bytes are in that file; to change it:
@ arm-none-eabi-as fault_probe.s -o p.o && arm-none-eabi-ld -Ttext=0x08000000 p.o -o p.elf &&
@ arm-none-eabi-objcopy -O binary p.elf p.bin, then the bytes of p.bin into the test).
@ Thread mode runs UDF with UsageFault enabled, then a load from 0x60000000 (no memory) with BusFault
@ disabled (HardFault, FORCED), then one from 0x60000004 with BusFault enabled. Each handler logs its
@ marker, HFSR (HardFault), CFSR, BFAR and the stacked pc at LOG, clears the status and returns past
@ the 16-bit instruction; each handler logs IPSR after its marker, and the thread at the end.
.syntax unified
.cpu cortex-m4
.thumb
.equ SHCSR, 0xE000ED24
.equ CFSR, 0xE000ED28
.equ HFSR, 0xE000ED2C
.equ BFAR, 0xE000ED38
.equ LOG, 0x20000100
.section .text
vectors:
	.word 0x20001000
	.word main
	.word 0
	.word hardfault
	.word 0
	.word busfault
	.word usagefault
	.rept 9
	.word 0
	.endr
.thumb_func
main:
	ldr r0, =SHCSR
	ldr r1, =(1 << 18)
	str r1, [r0]
	b 1f
1:	udf #0
	movs r0, #1
	bl log
	ldr r0, =0x60000000
	ldr r1, [r0]
	movs r0, #2
	bl log
	ldr r0, =SHCSR
	ldr r1, =(1 << 18) | (1 << 17)
	str r1, [r0]
	b 2f
2:	ldr r0, =0x60000004
	ldr r1, [r0]
	movs r0, #3
	bl log
	mrs r0, ipsr
	bl log
3:	wfi
	b 3b
.thumb_func
log:
	ldr r2, =LOG
	ldr r3, [r2]
	adds r3, #1
	str r3, [r2]
	str r0, [r2, r3, lsl #2]
	bx lr
@ a handler's common end: log CFSR, BFAR and the stacked pc, clear CFSR, skip the 16-bit instruction
.thumb_func
report_skip:
	push {r4, lr}
	ldr r4, =CFSR
	ldr r0, [r4]
	bl log
	str r0, [r4]
	ldr r0, =BFAR
	ldr r0, [r0]
	bl log
	ldr r0, [sp, #8 + 8 + 0x18]
	bl log
	ldr r0, [sp, #8 + 8 + 0x18]
	adds r0, #2
	str r0, [sp, #8 + 8 + 0x18]
	pop {r4, pc}
.thumb_func
hardfault:
	push {r4, lr}
	movs r0, #0x30
	bl log
	mrs r0, ipsr
	bl log
	ldr r4, =HFSR
	ldr r0, [r4]
	bl log
	str r0, [r4]
	bl report_skip
	pop {r4, pc}
.thumb_func
busfault:
	push {r4, lr}
	movs r0, #0x50
	bl log
	mrs r0, ipsr
	bl log
	bl report_skip
	pop {r4, pc}
.thumb_func
usagefault:
	push {r4, lr}
	movs r0, #0x60
	bl log
	mrs r0, ipsr
	bl log
	bl report_skip
	pop {r4, pc}
.ltorg
