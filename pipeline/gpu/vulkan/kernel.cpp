#include "kernel.hpp"

namespace rutd::gpu::vk {

Kernel KernelFactory::make(const std::uint32_t* spv, std::size_t bytes, std::uint32_t push_bytes,
                           const BindingsOf& bindings_of, const std::vector<std::int32_t>& spec,
                           VkPipelineCreateFlags flags) const {
  const VkDevice d = device_.handle();
  const Bindings bindings = bindings_of(*slots_[0]);
  Kernel k;
  k.bindings_of = bindings_of;
  try {
    std::vector<VkDescriptorSetLayoutBinding> lb(bindings.size());
    for (std::size_t i = 0; i < lb.size(); ++i) {
      lb[i] = VkDescriptorSetLayoutBinding{static_cast<std::uint32_t>(i), VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                           static_cast<std::uint32_t>(bindings[i].size()), VK_SHADER_STAGE_COMPUTE_BIT,
                                           nullptr};
    }
    auto li = info_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    li.bindingCount = static_cast<std::uint32_t>(lb.size());
    li.pBindings = lb.data();
    check(vkCreateDescriptorSetLayout(d, &li, nullptr, &k.set_layout), "vkCreateDescriptorSetLayout");
    const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
    auto pli = info_struct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    pli.setLayoutCount = 1;
    pli.pSetLayouts = &k.set_layout;
    pli.pushConstantRangeCount = 1;
    pli.pPushConstantRanges = &range;
    check(vkCreatePipelineLayout(d, &pli, nullptr, &k.layout), "vkCreatePipelineLayout");
    auto mi = info_struct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    mi.codeSize = bytes;
    mi.pCode = spv;
    check(vkCreateShaderModule(d, &mi, nullptr, &k.module), "vkCreateShaderModule");
    k.device = &device_;
    k.flags = flags;
    check(variant(k, spec, k.pipeline), "vkCreateComputePipelines");
    auto ai = info_struct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = pool_;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &k.set_layout;
    for (int slot = 0; slot < kSlots; ++slot) {
      VkDescriptorSet& set = k.sets[static_cast<std::size_t>(slot)];
      check(vkAllocateDescriptorSets(d, &ai, &set), "vkAllocateDescriptorSets");
      write_set(set, bindings_of(*slots_[static_cast<std::size_t>(slot)]));
    }
  } catch (...) {
    destroy(device_, k);
    throw;
  }
  return k;
}

void KernelFactory::rebind(const Kernel& k) const {
  if (k.pipeline == VK_NULL_HANDLE) return;
  for (int slot = 0; slot < kSlots; ++slot)
    write_set(k.sets[static_cast<std::size_t>(slot)], k.bindings_of(*slots_[static_cast<std::size_t>(slot)]));
}

void KernelFactory::write_set(VkDescriptorSet set, const Bindings& bindings) const {
  std::vector<std::vector<VkDescriptorBufferInfo>> bi(bindings.size());
  std::vector<VkWriteDescriptorSet> w(bindings.size());
  for (std::size_t i = 0; i < bindings.size(); ++i) {
    for (const Buffer* b : bindings[i]) bi[i].push_back(VkDescriptorBufferInfo{b->buffer, 0, VK_WHOLE_SIZE});
    w[i] = info_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    w[i].dstSet = set;
    w[i].dstBinding = static_cast<std::uint32_t>(i);
    w[i].descriptorCount = static_cast<std::uint32_t>(bi[i].size());
    w[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w[i].pBufferInfo = bi[i].data();
  }
  vkUpdateDescriptorSets(device_.handle(), static_cast<std::uint32_t>(w.size()), w.data(), 0, nullptr);
}

VkResult variant(Kernel& k, const std::vector<std::int32_t>& spec, VkPipeline& out) {
  out = VK_NULL_HANDLE;
  for (const auto& [values, pipeline] : k.variants) {
    if (values == spec) {
      out = pipeline;
      return VK_SUCCESS;
    }
  }
  auto ci = info_struct<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  ci.stage = info_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = k.module;
  ci.stage.pName = "main";
  std::vector<VkSpecializationMapEntry> entries;
  for (std::uint32_t i = 0; i < spec.size(); ++i)
    entries.push_back(VkSpecializationMapEntry{i, i * 4, sizeof(std::int32_t)});
  const VkSpecializationInfo spec_info{static_cast<std::uint32_t>(entries.size()), entries.data(),
                                       spec.size() * sizeof(std::int32_t), spec.data()};
  if (!spec.empty()) ci.stage.pSpecializationInfo = &spec_info;
  ci.layout = k.layout;
  ci.flags = k.flags;
  VkPipeline pipeline = VK_NULL_HANDLE;
  VkResult r = k.device->injected(VulkanCall::CreatePipeline);
  if (r == VK_SUCCESS) r = vkCreateComputePipelines(k.device->handle(), VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline);
  if (r != VK_SUCCESS) return r;
  k.variants.emplace_back(spec, pipeline);
  out = pipeline;
  return VK_SUCCESS;
}

void destroy(const Device& device, Kernel& k) {
  for (const auto& v : k.variants) vkDestroyPipeline(device.handle(), v.second, nullptr);
  vkDestroyShaderModule(device.handle(), k.module, nullptr);
  vkDestroyPipelineLayout(device.handle(), k.layout, nullptr);
  vkDestroyDescriptorSetLayout(device.handle(), k.set_layout, nullptr);
  k = Kernel{};
}

}  // namespace rutd::gpu::vk
