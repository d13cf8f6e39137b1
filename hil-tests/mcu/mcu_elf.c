/* The image loader: a little-endian ELF32 ARM executable (ELF: the System V ABI's object file format;
 * ARM: ELF for the Arm Architecture). Each PT_LOAD segment's file bytes go to its physical address
 * (the load address: .data's initial values sit in flash, start-up copies them); the rest of a segment
 * in memory is left to start-up, as on silicon. The symbol table (.symtab) names addresses in
 * reports. */
#include <stdlib.h>
#include <string.h>

#include "mcu.h"

#define EI_NIDENT 16
#define PT_LOAD 1
#define SHT_SYMTAB 2
#define EM_ARM 40
#define STT_FUNC 2
#define STT_OBJECT 1

static uint32_t le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint16_t le16(const uint8_t *p)
{
	return (uint16_t)(p[0] | p[1] << 8);
}

static int refuse(char *why, size_t len, const char *path, const char *reason)
{
	snprintf(why, len, "%s: %s", path, reason);
	return -1;
}

static int cmp_sym(const void *a, const void *b)
{
	const struct mcu_symbol *x = a, *y = b;

	return x->addr < y->addr ? -1 : x->addr > y->addr;
}

/* The function and object symbols, sorted by address (Thumb bit cleared). */
static void load_symbols(struct mcu *m, const uint8_t *f, size_t n)
{
	uint32_t shoff = le32(f + 32), shentsize = le16(f + 46), shnum = le16(f + 48), i;

	for (i = 0; i < shnum && shoff + (uint64_t)(i + 1) * shentsize <= n; i++) {
		const uint8_t *sh = f + shoff + (size_t)i * shentsize;
		uint32_t off = le32(sh + 16), size = le32(sh + 20), link = le32(sh + 24), k;
		const uint8_t *str_sh;
		uint32_t str_off, str_size;

		if (le32(sh + 4) != SHT_SYMTAB || link >= shnum || (uint64_t)off + size > n)
			continue;
		str_sh = f + shoff + (size_t)link * shentsize;
		str_off = le32(str_sh + 16);
		str_size = le32(str_sh + 20);
		if ((uint64_t)str_off + str_size > n || str_size == 0)
			continue;
		m->strtab = malloc(str_size + 1);
		m->sym = calloc(size / 16 + 1, sizeof(*m->sym));
		if (!m->strtab || !m->sym)
			return;
		memcpy(m->strtab, f + str_off, str_size);
		m->strtab[str_size] = 0;
		for (k = 0; k + 16 <= size; k += 16) {
			const uint8_t *s = f + off + k;
			uint32_t name = le32(s), type = s[12] & 0xFu;

			if ((type != STT_FUNC && type != STT_OBJECT) || name >= str_size || le16(s + 14) == 0)
				continue;
			m->sym[m->n_sym++] = (struct mcu_symbol){ le32(s + 4) & ~1u, le32(s + 8), m->strtab + name };
		}
		qsort(m->sym, m->n_sym, sizeof(*m->sym), cmp_sym);
		return;
	}
}

int mcu_load_elf(struct mcu *m, const char *path, char *why, size_t why_len)
{
	FILE *fp = fopen(path, "rb");
	uint8_t *f;
	long n;
	uint32_t phoff, phentsize, phnum, i, loaded = 0;

	if (!fp)
		return refuse(why, why_len, path, "cannot open");
	if (fseek(fp, 0, SEEK_END) != 0 || (n = ftell(fp)) < 52 || fseek(fp, 0, SEEK_SET) != 0) {
		fclose(fp);
		return refuse(why, why_len, path, "not an ELF file (too short)");
	}
	f = malloc((size_t)n);
	if (!f || fread(f, 1, (size_t)n, fp) != (size_t)n) {
		free(f);
		fclose(fp);
		return refuse(why, why_len, path, "cannot read");
	}
	fclose(fp);
	if (memcmp(f, "\177ELF", 4) != 0 || f[4] != 1 || f[5] != 1 || le16(f + 18) != EM_ARM) {
		free(f);
		return refuse(why, why_len, path, "not a little-endian ELF32 ARM file");
	}
	phoff = le32(f + 28);
	phentsize = le16(f + 42);
	phnum = le16(f + 44);
	for (i = 0; i < phnum; i++) {
		const uint8_t *ph = f + phoff + (size_t)i * phentsize;
		uint32_t off, paddr, filesz;

		if (phoff + (uint64_t)(i + 1) * phentsize > (uint64_t)n) {
			free(f);
			return refuse(why, why_len, path, "program headers past the end of the file");
		}
		if (le32(ph) != PT_LOAD)
			continue;
		off = le32(ph + 4);
		paddr = le32(ph + 12);
		filesz = le32(ph + 16);
		if (!filesz)
			continue;
		if ((uint64_t)off + filesz > (uint64_t)n) {
			free(f);
			return refuse(why, why_len, path, "a segment past the end of the file");
		}
		if (uc_mem_write(m->uc, paddr, f + off, filesz) != UC_ERR_OK) {
			char r[96];

			snprintf(r, sizeof(r), "a segment at 0x%08x (%u bytes) outside flash and RAM", paddr, filesz);
			free(f);
			return refuse(why, why_len, path, r);
		}
		loaded += filesz;
	}
	if (!loaded) {
		free(f);
		return refuse(why, why_len, path, "no loadable bytes");
	}
	load_symbols(m, f, (size_t)n);
	free(f);
	return 0;
}

const char *mcu_symbolize(const struct mcu *m, uint32_t addr, char *buf, size_t len)
{
	size_t lo = 0, hi = m->n_sym;

	while (lo < hi) { /* the last symbol at or below addr */
		size_t mid = (lo + hi) / 2;

		if (m->sym[mid].addr <= addr)
			lo = mid + 1;
		else
			hi = mid;
	}
	if (lo && addr - m->sym[lo - 1].addr < (m->sym[lo - 1].size ? m->sym[lo - 1].size : 1u))
		snprintf(buf, len, "0x%08x %s+0x%x", addr, m->sym[lo - 1].name, addr - m->sym[lo - 1].addr);
	else
		snprintf(buf, len, "0x%08x", addr);
	return buf;
}

uint32_t mcu_symbol_addr(const struct mcu *m, const char *name)
{
	for (size_t i = 0; i < m->n_sym; i++)
		if (strcmp(m->sym[i].name, name) == 0)
			return m->sym[i].addr;
	return 0;
}
