!> The table of a binary flight record, read by the core for both front
!> ends as tests/binary_reference.py's read_table reads it: a .mat file
!> (v5 by mlid_matfile; v7.3, HDF5 after a 512-byte header, by
!> mlid_hdf5file, its matrix transposed back to MATLAB's) or an HDF5 file
!> (.h5, .hdf5), then one table of its arrays (mlid_named_arrays).
module mlid_tablefile
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, short_path
  use mlid_files, only: not_regular, file_stamp_t, file_stamp, file_changed
  use mlid_named_arrays, only: named_array_t, arrays_table
  use mlid_matfile, only: matfile_read
  use mlid_hdf5file, only: hdf5file_read
  implicit none
  private
  public :: tablefile_read

  !> HDF5's signature, at byte 0 (or 512, 1024, ... after a user block).
  character(len=8), parameter :: HDF5_SIGNATURE = char(137)//'HDF'//achar(13)//achar(10)// &
                                                  achar(26)//achar(10)

contains

  !> x(nrow, ncol), a row per sample, with its columns' names and units
  !> ('' where the file names none; as long as the caller's, longer ones cut)
  !> of the record path.  variable: the array to take ('' for none named).
  subroutine tablefile_read(path, variable, x, names, units, status, msg)
    character(len=*), intent(in) :: path, variable
    real(wp), allocatable, intent(out) :: x(:, :)
    character(len=*), allocatable, intent(out) :: names(:), units(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(named_array_t), allocatable :: arrays(:)
    type(file_stamp_t) :: stamp
    logical :: hdf5, v73, mat
    integer :: n

    mat = ends_with(to_lower(trim(path)), '.mat')
    stamp = file_stamp(path)
    call sniff(path, hdf5, status, msg)
    if (status /= MLID_OK) return
    v73 = .false.
    if (.not. hdf5) then
      if (.not. mat) then
        status = MLID_ERR_INPUT
        msg = 'data file '//short_path(path)//': not an HDF5 file'
        return
      end if
      call matfile_read(path, arrays, n, v73, status, msg)
      if (status /= MLID_OK) return
    end if
    if (hdf5 .or. v73) then          ! a v7.3 header without HDF5 after it fails here
      call hdf5file_read(path, arrays, n, status, msg)
      if (status /= MLID_OK) return
    end if
    msg = file_changed(path, stamp)
    if (len_trim(msg) > 0) then
      status = MLID_ERR_INPUT
      msg = 'data file '//short_path(path)//' '//trim(msg)
      return
    end if
    call arrays_table(path, arrays(1:n), variable, mat .and. (hdf5 .or. v73), x, names, &
                      units, status, msg)
  end subroutine tablefile_read

  !> Whether path is HDF5: its signature at byte 0, or at 512 (a v7.3 .mat),
  !> the two places tests/binary_reference.py (h5py) looks.
  subroutine sniff(path, hdf5, status, msg)
    character(len=*), intent(in) :: path
    logical, intent(out) :: hdf5
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=8) :: head
    integer :: u, ios
    logical :: there, folder

    hdf5 = .false.
    folder = .false.
    status = MLID_ERR_INPUT
    inquire (file=path, exist=there)
    if (there) folder = not_regular(path) == 'a directory'      ! a folder is no file
    if (.not. there .or. folder) then
      msg = 'data file '//short_path(path)//': no such file'
      return
    end if
    if (len_trim(not_regular(path)) > 0) then
      msg = 'data file '//short_path(path)//' is '//trim(not_regular(path))// &
            ', not a regular file'
      return
    end if
    open (newunit=u, file=path, access='stream', form='unformatted', action='read', &
          status='old', iostat=ios)
    if (ios /= 0) then
      msg = 'data file '//short_path(path)//': cannot be opened'
      return
    end if
    read (u, pos=1, iostat=ios) head
    hdf5 = ios == 0 .and. head == HDF5_SIGNATURE
    if (.not. hdf5) then
      read (u, pos=513, iostat=ios) head
      hdf5 = ios == 0 .and. head == HDF5_SIGNATURE
    end if
    close (u)
    status = MLID_OK
    msg = ''
  end subroutine sniff

  logical function ends_with(s, tail)
    character(len=*), intent(in) :: s, tail
    ends_with = len(s) >= len(tail)
    if (ends_with) ends_with = s(len(s) - len(tail) + 1:) == tail
  end function ends_with

end module mlid_tablefile
