ply
format ascii 1.0
end_header
