@ exc_probe.s: the exception probe of test_cpu.cpp (its bytes are in that file; to change it:
@ arm-none-eabi-as exc_probe.s -o p.o && arm-none-eabi-ld -Ttext=0x08000000 p.o -o p.elf &&
@ arm-none-eabi-objcopy -O binary p.elf p.bin, then the bytes of p.bin into the test).
@ Thread mode with live FP state (s0, s15 = 1.5) and SP 4 bytes off 8-byte alignment pends IRQ0
@ (priority 0x80); IRQ0 clobbers s0, pends IRQ1 (0x40: preempts at once) and IRQ2 (0xC0: waits, then
@ tail-chains after IRQ0); then IRQ2 pended under PRIMASK waits for cpsie. Each handler and the thread
@ log a marker at LOG; the thread stores s0, s15 and SP after the handlers.
.syntax unified
.cpu cortex-m4
.fpu fpv4-sp-d16
.thumb
.equ AIRCR, 0xE000ED0C
.equ NVIC_ISER, 0xE000E100
.equ NVIC_ISPR, 0xE000E200
.equ NVIC_IPR, 0xE000E400
.equ LOG, 0x20000100
.section .text
vectors:
	.word 0x20001000
	.word main
	.rept 14
	.word 0
	.endr
	.word irq0
	.word irq1
	.word irq2
.thumb_func
main:
	ldr r0, =AIRCR
	ldr r1, =0x05FA0300
	str r1, [r0]
	ldr r0, =NVIC_IPR
	ldr r1, =0x00C04080
	str r1, [r0]
	ldr r0, =NVIC_ISER
	movs r1, #7
	str r1, [r0]
	ldr r0, =0x3FC00000
	vmov s0, r0
	vmov s15, r0
	sub sp, #4
	ldr r1, =LOG+0x48
	mov r0, sp
	str r0, [r1]
	ldr r0, =NVIC_ISPR
	movs r1, #1
	str r1, [r0]
	b 1f
1:	movs r0, #9
	bl log
	ldr r1, =LOG+0x40
	vmov r0, s0
	str r0, [r1]
	vmov r0, s15
	str r0, [r1, #4]
	mov r0, sp
	str r0, [r1, #12]
	cpsid i
	ldr r0, =NVIC_ISPR
	movs r1, #4
	str r1, [r0]
	b 2f
2:	movs r0, #8
	bl log
	cpsie i
	b 3f
3:	movs r0, #7
	bl log
4:	wfi
	b 4b
.thumb_func
log:
	ldr r2, =LOG
	ldr r3, [r2]
	adds r3, #1
	str r3, [r2]
	str r0, [r2, r3, lsl #2]
	bx lr
.thumb_func
irq0:
	push {r4, lr}
	movs r0, #0x10
	bl log
	ldr r0, =0x40000000
	vmov s0, r0
	ldr r0, =NVIC_ISPR
	movs r1, #2
	str r1, [r0]
	b 1f
1:	ldr r0, =NVIC_ISPR
	movs r1, #4
	str r1, [r0]
	b 2f
2:	movs r0, #0x11
	bl log
	pop {r4, pc}
.thumb_func
irq1:
	push {r4, lr}
	movs r0, #0x20
	bl log
	ldr r0, =0x40400000
	vmov s0, r0
	pop {r4, pc}
.thumb_func
irq2:
	push {r4, lr}
	movs r0, #0x30
	bl log
	pop {r4, pc}
.ltorg
