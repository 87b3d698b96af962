!> MATLAB v5 MAT-files (saved with -v6 or -v7), read as scipy.io.loadmat
!> reads them for tests/binary_reference.py, so that both give one table.
!>
!> A file is a 128-byte header (text, version, the endian indicator 'IM'
!> little- or 'MI' big-endian) and data elements, each a tag (type, byte
!> count) and its data: a matrix (miMATRIX: array flags, dimensions, name,
!> real part) or a zlib-compressed element (miCOMPRESSED) that holds one.
!> Parts of a matrix may use the small data element format (tag and up to 4
!> bytes in 8).  Numeric classes (double, single, int8..uint64, logical as
!> uint8) are taken, their values, whatever type they are stored in,
!> converted to real(wp) as numpy converts them; complex, char, cell,
!> struct, object, sparse and function arrays are passed over by their byte
!> count without being parsed, as tests/binary_reference.py (scipy) leaves them out.  A v7.3
!> header (version 0x0200) is said (v73), for the HDF5 reader to read it.
!>
!> Every length is checked against the bytes there are before a byte is
!> read, so a short or damaged file gives a message naming the file and
!> the byte, never a wrong table.
module mlid_matfile
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_int8_t
  use, intrinsic :: iso_fortran_env, only: int8, int16, int32, int64, real32
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: short_path
  use mlid_named_arrays, only: named_array_t, arrays_put, printable, itoa => count_text
  implicit none
  private
  public :: matfile_read, file_bytes

  !> Data types of elements and parts (MATLAB's MAT-File Format, table 1-1).
  integer, parameter :: MI_INT8 = 1, MI_UINT8 = 2, MI_INT16 = 3, MI_UINT16 = 4, MI_INT32 = 5, &
                        MI_UINT32 = 6, MI_SINGLE = 7, MI_DOUBLE = 9, MI_INT64 = 12, &
                        MI_UINT64 = 13, MI_MATRIX = 14, MI_COMPRESSED = 15
  !> Array classes of numbers: mxDOUBLE_CLASS (6) to mxUINT64_CLASS (15).
  integer, parameter :: MX_DOUBLE = 6, MX_UINT64 = 15
  integer, parameter :: Z_OK = 0
  integer(int64), parameter :: HEADER = 128
  !> deflate expands at most 1032:1, so a larger claim is a damaged stream.
  integer(int64), parameter :: MAX_RATIO = 1032

  !> Bytes being parsed, the file's or an inflated element's (offsets from
  !> 0), whether their byte order is the reverse of this machine's, and
  !> where they come from, for messages.
  type :: bytes_t
    integer(int8), allocatable :: b(:)
    logical :: swap = .false.
    character(len=:), allocatable :: where
  end type bytes_t

  interface
    !> zlib: inflate source into dest(destlen); destlen becomes the bytes
    !> given.  Z_OK: the whole stream, its checksum right.
    function uncompress(dest, destlen, source, sourcelen) bind(c, name='uncompress') result(rc)
      import :: c_int, c_long, c_int8_t
      integer(c_int8_t), intent(inout) :: dest(*)
      integer(c_long), intent(inout) :: destlen
      integer(c_int8_t), intent(in) :: source(*)
      integer(c_long), value, intent(in) :: sourcelen
      integer(c_int) :: rc
    end function uncompress
  end interface

contains

  !> The numeric arrays of the v5 MAT-file path, arrays(1:n) in the file's
  !> order; v73: the header says v7.3 (HDF5), nothing else read.
  subroutine matfile_read(path, arrays, n, v73, status, msg)
    character(len=*), intent(in) :: path
    type(named_array_t), allocatable, intent(out) :: arrays(:)
    integer, intent(out) :: n
    logical, intent(out) :: v73
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(bytes_t) :: f
    integer(int64) :: p

    n = 0
    v73 = .false.
    allocate (arrays(0))
    f%where = 'data file '//short_path(path)
    call file_bytes(path, f%b, status, msg)
    if (status /= MLID_OK) return
    call read_header(f, v73, status, msg)
    if (status /= MLID_OK .or. v73) return
    p = HEADER
    do while (p < size(f%b, kind=int64))      ! each element moves p on by 9 bytes or more
      call top_element(f, p, arrays, n, status, msg)
      if (status /= MLID_OK) return
    end do
  end subroutine matfile_read

  !> All bytes of the file path.
  subroutine file_bytes(path, b, status, msg)
    character(len=*), intent(in) :: path
    integer(int8), allocatable, intent(out) :: b(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(int64) :: nbyte
    integer :: u, ios, st

    status = MLID_ERR_INPUT
    open (newunit=u, file=path, access='stream', form='unformatted', action='read', &
          status='old', iostat=ios)
    if (ios /= 0) then
      msg = 'data file '//short_path(path)//': cannot be opened'
      return
    end if
    inquire (unit=u, size=nbyte)
    st = 1
    if (nbyte >= 0) allocate (b(nbyte), stat=st)
    if (st /= 0) then
      close (u)
      msg = 'data file '//short_path(path)//': cannot be held in memory ('//itoa(nbyte)//' bytes)'
      return
    end if
    ios = 0
    if (nbyte > 0) read (u, pos=1, iostat=ios) b
    close (u)
    if (ios /= 0) then
      msg = 'data file '//short_path(path)//': cannot be read'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine file_bytes

  !> The 128-byte header: the byte order, and the version (v5, or v7.3).
  subroutine read_header(f, v73, status, msg)
    type(bytes_t), intent(inout) :: f
    logical, intent(out) :: v73
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=2) :: endian
    integer :: major
    logical :: big_host

    status = MLID_ERR_INPUT
    v73 = .false.
    if (size(f%b, kind=int64) < HEADER) then
      msg = f%where//': not a MATLAB file ('//itoa(size(f%b))//' bytes, a MAT-file''s '// &
            'header alone has 128)'
      return
    end if
    if (any(f%b(1:4) == 0)) then      ! scipy's test for a v4 file
      msg = f%where//': not a MATLAB v5 file (a v4 file, or none); the core reads MAT-files '// &
            'saved with -v6, -v7 or -v7.3'
      return
    end if
    endian = achar(iand(int(f%b(127)), 255))//achar(iand(int(f%b(128)), 255))
    if (endian /= 'IM' .and. endian /= 'MI') then
      msg = f%where//': not a MATLAB file (no endian indicator IM or MI at byte 126)'
      return
    end if
    big_host = transfer(1_int16, 0_int8) == 0
    f%swap = (endian == 'MI') .neqv. big_host
    major = iand(int(f%b(merge(126, 125, endian == 'IM'))), 255)   ! the high byte
    if (major /= 1 .and. major /= 2) then
      msg = f%where//': not a MATLAB file (version '//itoa(major)//' in its header)'
      return
    end if
    v73 = major == 2
    status = MLID_OK
    msg = ''
  end subroutine read_header

  !> The element at byte p: a matrix, or a compressed one, added to arrays
  !> when it is numeric; p moves on past it.
  subroutine top_element(f, p, arrays, n, status, msg)
    type(bytes_t), intent(in) :: f
    integer(int64), intent(inout) :: p
    type(named_array_t), allocatable, intent(inout) :: arrays(:)
    integer, intent(inout) :: n
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(bytes_t) :: g
    type(named_array_t) :: item
    integer(int64) :: typ, nb, total
    logical :: numeric

    status = MLID_ERR_INPUT
    total = size(f%b, kind=int64)
    if (p + 8 > total) then
      msg = f%where//': truncated at byte '//itoa(total)//' (in the tag of an element at byte '// &
            itoa(p)//')'
      return
    end if
    typ = u32(f, p)
    nb = u32(f, p + 4)
    if (typ /= MI_MATRIX .and. typ /= MI_COMPRESSED) then
      msg = f%where//': the element at byte '//itoa(p)//' is of type '//itoa(typ)// &
            ', not a matrix (14) or compressed (15)'
      return
    end if
    if (nb == 0) then
      msg = f%where//': the element at byte '//itoa(p)//' is empty'
      return
    end if
    if (p + 8 + nb > total) then
      msg = f%where//': truncated at byte '//itoa(total)//' (the element at byte '//itoa(p)// &
            ' needs '//itoa(nb)//' bytes after its tag)'
      return
    end if
    if (typ == MI_MATRIX) then
      call parse_matrix(f, p + 8, p + 8 + nb, item, numeric, status, msg)
    else
      g%where = f%where//': compressed element at byte '//itoa(p)
      g%swap = f%swap
      call inflate(f%b(p + 9:p + 8 + nb), g, status, msg)
      if (status /= MLID_OK) return
      status = MLID_ERR_INPUT
      if (u32(g, 0_int64) /= MI_MATRIX) then
        msg = g%where//': holds an element of type '//itoa(u32(g, 0_int64))//', not a matrix'
        return
      end if
      call parse_matrix(g, 8_int64, size(g%b, kind=int64), item, numeric, status, msg)
    end if
    if (status /= MLID_OK) return
    if (numeric) call arrays_put(arrays, n, item, status, msg)
    p = p + 8 + nb
  end subroutine top_element

  !> g%b: the element that the zlib stream src holds, whole (its tag, then
  !> as many bytes as the tag says, and the stream's end right after).
  subroutine inflate(src, g, status, msg)
    integer(int8), intent(in) :: src(:)
    type(bytes_t), intent(inout) :: g
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(int8) :: head(8)
    integer(c_long) :: got
    integer(int64) :: want
    integer :: rc, st

    status = MLID_ERR_INPUT
    got = 8                       ! the tag first: it says how much there is
    rc = uncompress(head, got, src, int(size(src), c_long))
    if (got < 8) then
      msg = g%where//': zlib data damaged or cut short (zlib error '//itoa(rc)//')'
      return
    end if
    g%b = head
    want = 8 + u32(g, 4_int64)
    if (want > MAX_RATIO*size(src, kind=int64) + 64) then
      msg = g%where//': its element claims '//itoa(want)//' bytes from '//itoa(size(src))// &
            ' compressed (zlib data damaged)'
      return
    end if
    deallocate (g%b)
    allocate (g%b(want), stat=st)
    if (st /= 0) then
      msg = g%where//': cannot hold '//itoa(want)//' bytes inflated'
      return
    end if
    got = int(want, c_long)
    rc = uncompress(g%b, got, src, int(size(src), c_long))
    if (rc /= Z_OK .or. got /= want) then
      msg = g%where//': zlib data damaged, cut short or longer than its element (zlib error '// &
            itoa(rc)//', '//itoa(int(got, int64))//' of '//itoa(want)//' bytes)'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine inflate

  !> The matrix whose parts lie in bytes first..last-1 of s: item, when it
  !> is numeric (a real array of a number class with a value or more).
  subroutine parse_matrix(s, first, last, item, numeric, status, msg)
    type(bytes_t), intent(in) :: s
    integer(int64), intent(in) :: first, last
    type(named_array_t), intent(out) :: item
    logical, intent(out) :: numeric
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(int64) :: q, typ, nb, d, flags, cnt
    integer(int64), allocatable :: dims(:)
    integer :: k, cls, st

    numeric = .false.
    q = first
    call part(s, q, last, MI_UINT32, 'array flags', typ, nb, d, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (nb /= 8) then
      msg = s%where//': array flags at byte '//itoa(d)//' of '//itoa(nb)//' bytes, not 8'
      return
    end if
    flags = u32(s, d)
    cls = int(iand(flags, 255_int64))
    call part(s, q, last, MI_INT32, 'dimensions', typ, nb, d, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    dims = [(i32(s, d + 4*k), k=0, int(nb/4) - 1)]
    if (mod(nb, 4_int64) /= 0 .or. size(dims) == 0 .or. any(dims < 0)) then
      msg = s%where//': dimensions at byte '//itoa(d)//' are not a list of counts'
      return
    end if
    call part(s, q, last, MI_INT8, 'array name', typ, nb, d, status, msg)
    if (status /= MLID_OK) return
    allocate (character(len=nb) :: item%name)
    do k = 1, int(nb)
      item%name(k:k) = achar(iand(int(s%b(d + k)), 255))
    end do
    ! complex (flag bit 11) and every class but the numbers: not channels
    if (cls < MX_DOUBLE .or. cls > MX_UINT64 .or. btest(flags, 11)) return
    call part(s, q, last, 0, 'real part', typ, nb, d, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    call value_count(dims, cnt)
    if (width(typ) == 0 .or. cnt < 0 .or. nb /= cnt*width(typ)) then
      msg = s%where//': variable '//printable(item%name)//': '//itoa(nb)//' bytes of type '// &
            itoa(typ)//' for '//shape_text(dims)//' values'
      return
    end if
    allocate (item%v(cnt), stat=st)
    if (st /= 0) then
      msg = s%where//': variable '//printable(item%name)//': cannot hold '//itoa(cnt)//' values'
      return
    end if
    call decode(s, d, int(typ), item%v)
    item%shape = dims
    numeric = cnt > 0
    status = MLID_OK
  end subroutine parse_matrix

  !> The part of a matrix at byte q (before last), of type want (0: any):
  !> its type, byte count and where its data starts; q moves past it (its
  !> data padded to 8 bytes, or the 8 bytes of a small data element).
  subroutine part(s, q, last, want, what, typ, nb, d, status, msg)
    type(bytes_t), intent(in) :: s
    integer(int64), intent(inout) :: q
    integer(int64), intent(in) :: last
    integer, intent(in) :: want
    character(len=*), intent(in) :: what
    integer(int64), intent(out) :: typ, nb, d
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(int64) :: w

    status = MLID_ERR_INPUT
    typ = 0
    nb = 0
    d = q
    if (q + 8 > last) then
      msg = s%where//': a matrix ends at byte '//itoa(last)//', before its '//what
      return
    end if
    w = u32(s, q)
    if (shiftr(w, 16) /= 0) then            ! small data element: 2-byte count and type
      nb = shiftr(w, 16)
      typ = iand(w, 65535_int64)
      d = q + 4
      q = q + 8
      if (nb > 4) then
        msg = s%where//': '//what//' at byte '//itoa(d - 4)//': a small element of '// &
              itoa(nb)//' bytes'
        return
      end if
    else
      typ = w
      nb = u32(s, q + 4)
      d = q + 8
      if (d + nb > last) then
        msg = s%where//': '//what//' at byte '//itoa(q)//' needs '//itoa(nb)// &
              ' bytes, its matrix ends at byte '//itoa(last)
        return
      end if
      q = d + 8*((nb + 7)/8)
    end if
    if (want /= 0 .and. typ /= want) then
      msg = s%where//': '//what//' at byte '//itoa(d)//' of type '//itoa(typ)//', not '// &
            itoa(want)
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine part

  !> The number of values of an array of dimensions dims; -1 beyond int64.
  pure subroutine value_count(dims, cnt)
    integer(int64), intent(in) :: dims(:)
    integer(int64), intent(out) :: cnt
    integer :: k
    cnt = 1
    do k = 1, size(dims)
      if (dims(k) == 0) then
        cnt = 0
        return
      end if
      if (cnt > huge(cnt)/dims(k)) then
        cnt = -1
        return
      end if
      cnt = cnt*dims(k)
    end do
  end subroutine value_count

  !> Bytes per value of a numeric data type; 0 for any other type.
  pure integer function width(typ)
    integer(int64), intent(in) :: typ
    select case (typ)
    case (MI_INT8, MI_UINT8)
      width = 1
    case (MI_INT16, MI_UINT16)
      width = 2
    case (MI_INT32, MI_UINT32, MI_SINGLE)
      width = 4
    case (MI_DOUBLE, MI_INT64, MI_UINT64)
      width = 8
    case default
      width = 0
    end select
  end function width

  !> v(:) from the values of type typ from byte d of s (checked to be there).
  subroutine decode(s, d, typ, v)
    type(bytes_t), intent(in) :: s
    integer(int64), intent(in) :: d
    integer, intent(in) :: typ
    real(wp), intent(out) :: v(:)
    integer(int8) :: c(8)
    integer(int64) :: q, i
    integer :: w

    w = width(int(typ, int64))
    do i = 1, size(v, kind=int64)
      q = d + (i - 1)*w
      c(1:w) = s%b(q + 1:q + w)
      if (s%swap) c(1:w) = c(w:1:-1)
      select case (typ)
      case (MI_DOUBLE)
        v(i) = transfer(c, 0.0_wp)
      case (MI_SINGLE)
        v(i) = real(transfer(c(1:4), 0.0_real32), wp)
      case (MI_INT8)
        v(i) = real(c(1), wp)
      case (MI_UINT8)
        v(i) = real(iand(int(c(1), int32), 255), wp)
      case (MI_INT16)
        v(i) = real(transfer(c(1:2), 0_int16), wp)
      case (MI_UINT16)
        v(i) = real(iand(int(transfer(c(1:2), 0_int16), int32), 65535), wp)
      case (MI_INT32)
        v(i) = real(transfer(c(1:4), 0_int32), wp)
      case (MI_UINT32)
        v(i) = real(iand(int(transfer(c(1:4), 0_int32), int64), 4294967295_int64), wp)
      case (MI_INT64)
        v(i) = real(transfer(c, 0_int64), wp)
      case (MI_UINT64)
        v(i) = unsigned64(transfer(c, 0_int64))
      end select
    end do
  end subroutine decode

  !> The uint64 whose bits are i, rounded once to real(wp) as numpy rounds
  !> it: its two halves are exact, so only their sum rounds.
  elemental real(wp) function unsigned64(i) result(x)
    integer(int64), intent(in) :: i
    if (i >= 0) then
      x = real(i, wp)
    else
      x = real(shiftr(i, 32), wp)*4294967296.0_wp + real(iand(i, 4294967295_int64), wp)
    end if
  end function unsigned64

  !> The uint32 at byte p of s, in the file's byte order.
  integer(int64) function u32(s, p)
    type(bytes_t), intent(in) :: s
    integer(int64), intent(in) :: p
    integer(int8) :: c(4)
    c = s%b(p + 1:p + 4)
    if (s%swap) c = c(4:1:-1)
    u32 = iand(int(transfer(c, 0_int32), int64), 4294967295_int64)
  end function u32

  !> The int32 at byte p of s, in the file's byte order.
  integer(int64) function i32(s, p)
    type(bytes_t), intent(in) :: s
    integer(int64), intent(in) :: p
    integer(int8) :: c(4)
    c = s%b(p + 1:p + 4)
    if (s%swap) c = c(4:1:-1)
    i32 = int(transfer(c, 0_int32), int64)
  end function i32

  !> '3 x 4' for a message.
  function shape_text(dims) result(text)
    integer(int64), intent(in) :: dims(:)
    character(len=:), allocatable :: text
    integer :: k
    text = itoa(dims(1))
    do k = 2, min(size(dims), 8)
      text = text//' x '//itoa(dims(k))
    end do
  end function shape_text

end module mlid_matfile
