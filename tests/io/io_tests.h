/* Tests defined in the other files of the test_io executable. */
#ifndef HZ_TEST_IO_TESTS_H
#define HZ_TEST_IO_TESTS_H

void test_mutation_fuzz(void **state);
void test_real_hgt(void **state);
void test_real_png(void **state);
void test_real_sierra_mosaic(void **state);
void test_real_fill_voids_n46e008(void **state);
void test_gdal_real_native(void **state);
void test_gdal_spacing_44n(void **state);
void test_gdal_nodata_terrain(void **state);
void test_gdal_mosaic_equals_single(void **state);
void test_gdal_formats(void **state);
void test_gdal_units(void **state);
void test_fit_keeps_every_sample(void **state);
void test_gdal_broken(void **state);
void test_gdal_leaves_inputs_alone(void **state);
void test_gpu_limit_advice(void **state);
void test_gdal_sierra_coast(void **state);

/* FNV-1a of the float bits of hz_generate(size 257, seed 2024). */
#define GOLDEN_PERLIN_257_2024 0xd77b38417c60199cULL
#define GOLDEN_DIAMOND_257_2024 0xa1cde20ad5f8b29cULL

#endif
