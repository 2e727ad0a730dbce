/* core/contract_gpu.c: the contract as GPU images (formats from shaders/contract.h) and the
 * copies between them and host frames. Packing for upload uses the same encodings as the GPU
 * (shaders/encoding.h), so a frame survives upload + download bit for bit once quantised.
 * Entry points: tnd_ct_format, tnd_contract_gpu_create/destroy, tnd_contract_upload/download. */
#include "core/core.h"
#include "shaders/encoding.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

VkFormat tnd_ct_format(tnd_ct id, tnd_precision p)
{
    const tnd_ct_info *e = tnd_ct_get(id);
    return p == TND_PRECISION_PACKED ? e->vk_packed : e->vk_f32;
}

/* Channels of the image format and bytes per channel (RGBE: one 4-byte channel). */
static void texel_layout(tnd_ct id, tnd_precision p, uint32_t *channels, uint32_t *bytes)
{
    switch (tnd_ct_format(id, p)) {
    case VK_FORMAT_R32G32B32A32_SFLOAT:
        *channels = 4, *bytes = 4;
        break;
    case VK_FORMAT_R16G16B16A16_SFLOAT:
        *channels = 4, *bytes = 2;
        break;
    case VK_FORMAT_R32G32_SFLOAT:
    case VK_FORMAT_R32G32_UINT:
        *channels = 2, *bytes = 4;
        break;
    case VK_FORMAT_R16G16_SFLOAT:
        *channels = 2, *bytes = 2;
        break;
    case VK_FORMAT_R16_SFLOAT:
        *channels = 1, *bytes = 2;
        break;
    default: /* R32_SFLOAT, R32_UINT (RGBE) */
        *channels = 1, *bytes = 4;
        break;
    }
}

uint32_t tnd_ct_texel_bytes(tnd_ct id, tnd_precision p)
{
    uint32_t ch, b;
    texel_layout(id, p, &ch, &b);
    return ch * b;
}

void tnd_contract_gpu_destroy(tnd_vk *vk, tnd_contract_gpu *c)
{
    for (int i = 0; i < TND_CT_COUNT; i++)
        tnd_image_destroy(vk, &c->images[i]);
    memset(c, 0, sizeof *c);
}

tnd_result tnd_contract_gpu_create(tnd_vk *vk, uint32_t width, uint32_t height, tnd_precision p,
                                   tnd_contract_gpu *c)
{
    static atomic_uint_fast64_t serials;
    memset(c, 0, sizeof *c);
    c->precision = p;
    c->width = width;
    c->height = height;
    c->serial = (uint64_t)atomic_fetch_add(&serials, 1) + 1;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        char name[64];
        snprintf(name, sizeof name, "contract.%s", tnd_ct_get((tnd_ct)i)->name);
        tnd_result r = tnd_image_create(vk,
                                        &(tnd_image_desc){.width = width,
                                                          .height = height,
                                                          .format = tnd_ct_format((tnd_ct)i, p),
                                                          .name = name},
                                        &c->images[i]);
        if (r != TND_OK) {
            tnd_contract_gpu_destroy(vk, c);
            return r;
        }
    }
    return TND_OK;
}

static size_t total_bytes(const tnd_contract_gpu *c, size_t *offsets)
{
    size_t off = 0, n = (size_t)c->width * c->height;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        offsets[i] = off;
        off += (n * tnd_ct_texel_bytes((tnd_ct)i, c->precision) + 15) & ~(size_t)15;
    }
    return off;
}

static void pack_entry(const tnd_contract_gpu *c, const tnd_frame *f, int i, uint8_t *dst)
{
    const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
    size_t n = (size_t)c->width * c->height;
    uint32_t ch, b;
    texel_layout((tnd_ct)i, c->precision, &ch, &b);
    tnd_ct_pack pack = c->precision == TND_PRECISION_PACKED ? e->pack : TND_PACK_F32;
    if (e->kind == TND_CT_UINT) {
        memcpy(dst, f->data[i], n * e->comps * 4); /* RG32_UINT, comps == channels */
        return;
    }
    const float *src = f->data[i];
    for (size_t q = 0; q < n; q++) {
        const float *px = src + q * e->comps;
        if (pack == TND_PACK_RGBE) {
            uint32_t v = tnd_rgbe_encode(px[0], px[1], px[2]);
            memcpy(dst + 4 * q, &v, 4);
            continue;
        }
        for (uint32_t k = 0; k < ch; k++) {
            float v = k < e->comps ? px[k] : 0.0f;
            if (b == 2) {
                uint16_t h = tnd_half_from_float(v);
                memcpy(dst + (q * ch + k) * 2, &h, 2);
            } else {
                v = tnd_sanitize(v, 3.4028234663852886e38f);
                memcpy(dst + (q * ch + k) * 4, &v, 4);
            }
        }
    }
}

static void unpack_entry(const tnd_contract_gpu *c, tnd_frame *f, int i, const uint8_t *src)
{
    const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
    size_t n = (size_t)c->width * c->height;
    uint32_t ch, b;
    texel_layout((tnd_ct)i, c->precision, &ch, &b);
    tnd_ct_pack pack = c->precision == TND_PRECISION_PACKED ? e->pack : TND_PACK_F32;
    if (e->kind == TND_CT_UINT) {
        memcpy(f->data[i], src, n * e->comps * 4);
        return;
    }
    float *dst = f->data[i];
    for (size_t q = 0; q < n; q++) {
        float *px = dst + q * e->comps;
        if (pack == TND_PACK_RGBE) {
            uint32_t v;
            memcpy(&v, src + 4 * q, 4);
            for (int k = 0; k < 3; k++)
                px[k] = tnd_rgbe_channel(v, k);
            continue;
        }
        for (uint32_t k = 0; k < e->comps; k++) {
            if (b == 2) {
                uint16_t h;
                memcpy(&h, src + (q * ch + k) * 2, 2);
                px[k] = tnd_half_to_float(h);
            } else {
                memcpy(&px[k], src + (q * ch + k) * 4, 4);
            }
        }
    }
}

static tnd_result copy_all(tnd_vk *vk, const tnd_contract_gpu *c, tnd_buffer *staging,
                           const size_t *offsets, bool to_images)
{
    tnd_result res = TND_OK;
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    tnd_cmd_barrier(cmd);
    for (int i = 0; i < TND_CT_COUNT; i++) {
        VkBufferImageCopy r = {.bufferOffset = offsets[i],
                               .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                               .imageExtent = {c->width, c->height, 1}};
        if (to_images)
            vkCmdCopyBufferToImage(cmd, staging->buffer, c->images[i].image,
                                   VK_IMAGE_LAYOUT_GENERAL, 1, &r);
        else
            vkCmdCopyImageToBuffer(cmd, c->images[i].image, VK_IMAGE_LAYOUT_GENERAL,
                                   staging->buffer, 1, &r);
    }
    tnd_cmd_barrier(cmd);
    res = tnd_cmd_submit_wait(vk, cmd);
fail:
    return res;
}

tnd_result tnd_contract_upload(tnd_vk *vk, tnd_contract_gpu *c, const tnd_frame *f)
{
    tnd_result res = TND_OK;
    if (f->width != c->width || f->height != c->height)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "contract: upload of %ux%u into %ux%u images",
                        f->width, f->height, c->width, c->height);
    size_t offsets[TND_CT_COUNT];
    size_t total = total_bytes(c, offsets);
    tnd_buffer st = {0};
    TND_TRY(tnd_buffer_create(
        vk, &(tnd_buffer_desc){.size = total, .mem = TND_MEM_UPLOAD, .name = "contract.upload"},
        &st));
    for (int i = 0; i < TND_CT_COUNT; i++)
        pack_entry(c, f, i, (uint8_t *)st.mapped + offsets[i]);
    res = copy_all(vk, c, &st, offsets, true);
fail:
    tnd_buffer_destroy(vk, &st);
    return res;
}

tnd_result tnd_contract_download(tnd_vk *vk, const tnd_contract_gpu *c, tnd_frame *f)
{
    tnd_result res = TND_OK;
    if (f->width != c->width || f->height != c->height)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "contract: download of %ux%u into %ux%u frame",
                        c->width, c->height, f->width, f->height);
    size_t offsets[TND_CT_COUNT];
    size_t total = total_bytes(c, offsets);
    tnd_buffer st = {0};
    TND_TRY(tnd_buffer_create(
        vk, &(tnd_buffer_desc){.size = total, .mem = TND_MEM_READBACK, .name = "contract.download"},
        &st));
    TND_TRY(copy_all(vk, c, &st, offsets, false));
    for (int i = 0; i < TND_CT_COUNT; i++) {
        unpack_entry(c, f, i, (const uint8_t *)st.mapped + offsets[i]);
        f->present[i] = true;
    }
    f->precision = c->precision;
fail:
    tnd_buffer_destroy(vk, &st);
    return res;
}

tnd_result tnd_contract_set_layout(tnd_vk *vk, VkShaderStageFlags stages,
                                   VkDescriptorSetLayout *layout)
{
    tnd_result res = TND_OK;
    VkDescriptorSetLayoutBinding b[TND_CT_COUNT];
    for (uint32_t i = 0; i < TND_CT_COUNT; i++)
        b[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, stages, NULL};
    VkDescriptorSetLayoutCreateInfo ci = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                          .bindingCount = TND_CT_COUNT,
                                          .pBindings = b};
    TND_VK_TRY(vkCreateDescriptorSetLayout(vk->device, &ci, NULL, layout));
fail:
    return res;
}

void tnd_contract_write_set(tnd_vk *vk, VkDescriptorSet set, const tnd_contract_gpu *c)
{
    VkDescriptorImageInfo ii[TND_CT_COUNT];
    VkWriteDescriptorSet w[TND_CT_COUNT];
    for (uint32_t i = 0; i < TND_CT_COUNT; i++) {
        ii[i] = (VkDescriptorImageInfo){VK_NULL_HANDLE, c->images[i].view, VK_IMAGE_LAYOUT_GENERAL};
        w[i] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                      .dstSet = set,
                                      .dstBinding = i,
                                      .descriptorCount = 1,
                                      .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                      .pImageInfo = &ii[i]};
    }
    vkUpdateDescriptorSets(vk->device, TND_CT_COUNT, w, 0, NULL);
}
